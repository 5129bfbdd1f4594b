// SPDX-License-Identifier: GPL-3.0-or-later
//
// ResponseOptions' and MergeOptions' rules and canonical JSON.
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"

namespace hdrstereo::hdr {

absl::Status ResponseOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(lambda >= 0 && std::isfinite(lambda), "lambda",
                               lambda, ">= 0 (smoothness weight)"));
  return RequireField(samples >= 2, "samples", samples,
                      ">= 2 (pixels sampled per channel)");
}

void to_json(nlohmann::json& j, const ResponseOptions& o) {
  const auto& [lambda, samples, seed] = o;
  j = nlohmann::json{{"lambda", lambda}, {"samples", samples}, {"seed", seed}};
}

absl::Status MergeOptions::Validate() const {
  if (!weights.empty() && static_cast<int>(weights.size()) != kLevels) {
    return absl::InvalidArgumentError(
        absl::StrCat("weights has ", weights.size(), " entries; it needs ",
                     kLevels, " (one per 8-bit code) or none"));
  }
  for (size_t z = 0; z < weights.size(); ++z) {
    RETURN_IF_ERROR(RequireField(weights[z] >= 0 && std::isfinite(weights[z]),
                                 absl::StrCat("weights[", z, "]"), weights[z],
                                 ">= 0"));
  }
  return RequireField(linear_saturation > 0 && linear_saturation <= 1,
                      "linear_saturation", linear_saturation,
                      "in (0, 1] (fraction of full scale)");
}

void to_json(nlohmann::json& j, const MergeOptions& o) {
  const auto& [weights, per_channel_weights, linear_saturation] = o;
  j = nlohmann::json{{"weights", weights},
                     {"per_channel_weights", per_channel_weights},
                     {"linear_saturation", linear_saturation}};
}

}  // namespace hdrstereo::hdr
