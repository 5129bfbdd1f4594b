// SPDX-License-Identifier: GPL-3.0-or-later
//
// ResponseOptions', MergeOptions' and AutoBracketOptions' rules and
// canonical JSON.
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/hdr/auto_bracket.h"
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

absl::Status AutoBracketOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(min_snr >= 10 && min_snr <= 1000, "min_snr",
                               min_snr,
                               "in [10, 1000] (10: ISO 12232 \"acceptable\")"));
  RETURN_IF_ERROR(RequireField(max_step_stops >= 1.0 / 3 && max_step_stops <= 8,
                               "max_step_stops", max_step_stops,
                               "in [1/3, 8] stops"));
  RETURN_IF_ERROR(RequireField(
      exclude_emitters_above == 0 ||
          (exclude_emitters_above > 1 && std::isfinite(exclude_emitters_above)),
      "exclude_emitters_above", exclude_emitters_above,
      "0 (keep emitters) or > 1 (times the view's median radiance)"));
  RETURN_IF_ERROR(RequireField(
      max_uncovered_fraction >= 0 && max_uncovered_fraction < 1,
      "max_uncovered_fraction", max_uncovered_fraction, "in [0, 1)"));
  return RequireField(max_exposure_s >= 0 && std::isfinite(max_exposure_s),
                      "max_exposure_s", max_exposure_s,
                      ">= 0 s (0: the camera's longest)");
}

void to_json(nlohmann::json& j, const AutoBracketOptions& o) {
  const auto& [min_snr, max_step_stops, exclude_emitters_above,
               max_uncovered_fraction, max_exposure_s] = o;
  j = nlohmann::json{{"min_snr", min_snr},
                     {"max_step_stops", max_step_stops},
                     {"exclude_emitters_above", exclude_emitters_above},
                     {"max_uncovered_fraction", max_uncovered_fraction},
                     {"max_exposure_s", max_exposure_s}};
}

}  // namespace hdrstereo::hdr
