// SPDX-License-Identifier: GPL-3.0-or-later
//
// Durations and points in time as people type them on the command line:
// "90s", "30m", "2h", "7d", "1w" (or plain seconds); "2026-11-23",
// "2026-11-23 14:05" (local time) or a duration back from now.
#ifndef HDRSTEREO_CLIENTS_CLI_TIME_ARGS_H_
#define HDRSTEREO_CLIENTS_CLI_TIME_ARGS_H_

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

namespace hdrstereo::cli {

// A positive duration; INVALID_ARGUMENT naming the text otherwise.
absl::StatusOr<absl::Duration> ParseDurationArg(absl::string_view text);

// A date or date and time in `zone`, or a duration before `now` ("2h" =
// two hours ago).
absl::StatusOr<absl::Time> ParseTimeArg(absl::string_view text, absl::Time now,
                                        absl::TimeZone zone);

}  // namespace hdrstereo::cli

#endif  // HDRSTEREO_CLIENTS_CLI_TIME_ARGS_H_
