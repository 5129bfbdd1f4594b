// SPDX-License-Identifier: GPL-3.0-or-later
//
// The line `hdrstereo jobs watch` redraws on a terminal while a job runs.
#ifndef HDRSTEREO_CLIENTS_CLI_PROGRESS_BAR_H_
#define HDRSTEREO_CLIENTS_CLI_PROGRESS_BAR_H_

#include <cstdint>
#include <string>

#include "absl/strings/string_view.h"

namespace hdrstereo::cli {

// "[#########---------------------] 3/10  30%  0.50/s ETA 0:00:14  <step>":
// a 30-character bar, done/total as reported, the percentage, `rate` (units
// per second; ETA "--:--" unless > 0) and the first 40 bytes of `step`,
// each byte that is not printable ASCII shown as '?' (the step comes from a
// cluster log). The bar, percentage and ETA use `done` clamped to
// [0, total]: a cluster log may report more steps than it announced
// ("[7/3]"); total <= 0 gives an empty bar at 0 %.
std::string ProgressLine(int64_t done, int64_t total, double rate,
                         absl::string_view step);

// "h:mm:ss", rounded to the second; "--:--" when negative, not a number or
// over 100 hours.
std::string FormatDuration(double seconds);

}  // namespace hdrstereo::cli

#endif  // HDRSTEREO_CLIENTS_CLI_PROGRESS_BAR_H_
