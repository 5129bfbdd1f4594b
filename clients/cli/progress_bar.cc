// SPDX-License-Identifier: GPL-3.0-or-later
#include "clients/cli/progress_bar.h"

#include <algorithm>

#include "absl/strings/ascii.h"
#include "absl/strings/str_format.h"

namespace hdrstereo::cli {

std::string ProgressLine(int64_t done, int64_t total, double rate,
                         absl::string_view step) {
  constexpr int kWidth = 30;
  constexpr int kStepBytes = 40;
  // The step's name comes from the cluster's log: every byte that is not
  // printable ASCII (a control character, or part of a multi-byte character
  // the cut could split) is shown as '?', so none reaches the terminal.
  std::string shown(step.substr(0, kStepBytes));
  for (char& c : shown) {
    if (!absl::ascii_isprint(c)) c = '?';
  }
  const int64_t clamped = total > 0 ? std::clamp<int64_t>(done, 0, total) : 0;
  const double fraction =
      total > 0 ? static_cast<double>(clamped) / static_cast<double>(total)
                : 0.0;
  const int filled = static_cast<int>(kWidth * fraction);  // 0 .. kWidth
  const double left =
      static_cast<double>(std::max<int64_t>(0, total - clamped));
  return absl::StrFormat(
      "[%s%s] %d/%d %3.0f%% %5.2f/s ETA %s  %-*s", std::string(filled, '#'),
      std::string(kWidth - filled, '-'), done, total, 100.0 * fraction, rate,
      rate > 0 ? FormatDuration(left / rate) : "--:--", kStepBytes, shown);
}

std::string FormatDuration(double seconds) {
  if (!(seconds >= 0) || seconds > 360000) return "--:--";
  const int s = static_cast<int>(seconds + 0.5);
  return absl::StrFormat("%d:%02d:%02d", s / 3600, (s / 60) % 60, s % 60);
}

}  // namespace hdrstereo::cli
