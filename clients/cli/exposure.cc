// SPDX-License-Identifier: GPL-3.0-or-later
#include "clients/cli/exposure.h"

#include <cmath>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::cli {

absl::StatusOr<double> ParseExposure(absl::string_view text) {
  absl::string_view t = absl::StripAsciiWhitespace(text);
  absl::ConsumeSuffix(&t, "s");
  t = absl::StripAsciiWhitespace(t);
  double seconds = 0;
  std::pair<absl::string_view, absl::string_view> parts =
      absl::StrSplit(t, absl::MaxSplits('/', 1));
  double numerator = 0, denominator = 1;
  bool ok = absl::SimpleAtod(parts.first, &numerator);
  if (ok && !parts.second.empty()) {
    ok = absl::SimpleAtod(parts.second, &denominator) && denominator > 0;
  }
  if (ok) seconds = numerator / denominator;
  if (!ok || !std::isfinite(seconds) || seconds <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "exposure \"", text, "\" is not a positive time like 1/125, 0.5 or 2"));
  }
  return seconds;
}

absl::StatusOr<std::vector<double>> ParseExposureList(absl::string_view text) {
  std::vector<double> list;
  for (absl::string_view item : absl::StrSplit(text, ',')) {
    ASSIGN_OR_RETURN(double seconds, ParseExposure(item));
    list.push_back(seconds);
  }
  return list;
}

std::string FormatExposure(double seconds) {
  if (seconds < 0.4) {
    const double denominator = 1.0 / seconds;
    if (std::abs(denominator - std::round(denominator)) < 0.01 * denominator) {
      return absl::StrFormat("1/%.0f s", denominator);
    }
  }
  return absl::StrFormat("%g s", seconds);
}

}  // namespace hdrstereo::cli
