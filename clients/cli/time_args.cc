// SPDX-License-Identifier: GPL-3.0-or-later
#include "clients/cli/time_args.h"

#include <string>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace hdrstereo::cli {

absl::StatusOr<absl::Duration> ParseDurationArg(absl::string_view text) {
  absl::Duration duration;
  int64_t count = 0;
  const absl::string_view number =
      text.substr(0, text.empty() ? 0 : text.size() - 1);
  bool parsed = false;
  if (!text.empty() && (text.back() == 'd' || text.back() == 'w') &&
      absl::SimpleAtoi(number, &count)) {
    duration = absl::Hours(24 * (text.back() == 'w' ? 7 : 1)) * count;
    parsed = true;
  } else if (absl::SimpleAtoi(text, &count)) {
    duration = absl::Seconds(count);
    parsed = true;
  } else {
    parsed = absl::ParseDuration(text, &duration);
  }
  if (!parsed || duration <= absl::ZeroDuration() ||
      duration == absl::InfiniteDuration()) {
    return absl::InvalidArgumentError(
        absl::StrCat("\"", text,
                     "\" is not a positive duration; write e.g. 90s, 30m, "
                     "2h, 7d or 1w"));
  }
  return duration;
}

absl::StatusOr<absl::Time> ParseTimeArg(absl::string_view text, absl::Time now,
                                        absl::TimeZone zone) {
  for (const char* format :
       {"%Y-%m-%d %H:%M:%S", "%Y-%m-%d %H:%M", "%Y-%m-%dT%H:%M:%S",
        "%Y-%m-%dT%H:%M", "%Y-%m-%d"}) {
    absl::Time time;
    if (absl::ParseTime(format, std::string(text), zone, &time, nullptr)) {
      return time;
    }
  }
  absl::StatusOr<absl::Duration> ago = ParseDurationArg(text);
  if (ago.ok()) return now - *ago;
  return absl::InvalidArgumentError(
      absl::StrCat("\"", text,
                   "\" is neither a time (2026-11-23, 2026-11-23 14:05) nor "
                   "a duration back from now (30m, 2h, 7d)"));
}

}  // namespace hdrstereo::cli
