// SPDX-License-Identifier: GPL-3.0-or-later
//
// Exposure times as photographers write them: "1/125", "0.5", "2", "2s".
#ifndef HDRSTEREO_CLIENTS_CLI_EXPOSURE_H_
#define HDRSTEREO_CLIENTS_CLI_EXPOSURE_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::cli {

// Seconds > 0; INVALID_ARGUMENT naming the text otherwise.
absl::StatusOr<double> ParseExposure(absl::string_view text);
// A comma-separated list, e.g. "1/15,1/30,1/60".
absl::StatusOr<std::vector<double>> ParseExposureList(absl::string_view text);
// "1/125 s" for short exposures, "0.5 s" / "2 s" otherwise.
std::string FormatExposure(double seconds);

}  // namespace hdrstereo::cli

#endif  // HDRSTEREO_CLIENTS_CLI_EXPOSURE_H_
