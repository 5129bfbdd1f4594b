// SPDX-License-Identifier: GPL-3.0-or-later
//
// The tone-mapping parameters' rules and canonical JSON.
#include <cmath>
#include <nlohmann/json.hpp>

#include "processing/base/options.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::tonemap {

absl::Status ReinhardOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(key > 0 && std::isfinite(key), "key", key,
                               "> 0 (the photographic key)"));
  return RequireField(std::isfinite(white), "white", white,
                      "finite (<= 0 = the largest luminance)");
}

void to_json(nlohmann::json& j, const ReinhardOptions& o) {
  const auto& [key, white] = o;
  j = nlohmann::json{{"key", key}, {"white", white}};
}

absl::Status DragoOptions::Validate() const {
  RETURN_IF_ERROR(
      RequireField(bias > 0 && bias < 1, "bias", bias, "in (0, 1)"));
  return RequireField(ld_max > 0 && std::isfinite(ld_max), "ld_max", ld_max,
                      "> 0 (cd/m^2)");
}

void to_json(nlohmann::json& j, const DragoOptions& o) {
  const auto& [bias, ld_max] = o;
  j = nlohmann::json{{"bias", bias}, {"ld_max", ld_max}};
}

absl::Status DurandOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(sigma_s_fraction > 0, "sigma_s_fraction",
                               sigma_s_fraction, "> 0"));
  return RequireField(sigma_r > 0, "sigma_r", sigma_r, "> 0 (log10 units)");
}

void to_json(nlohmann::json& j, const DurandOptions& o) {
  const auto& [sigma_s_fraction, sigma_r] = o;
  j = nlohmann::json{{"sigma_s_fraction", sigma_s_fraction},
                     {"sigma_r", sigma_r}};
}

absl::Status FattalOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(alpha > 0, "alpha", alpha, "> 0"));
  RETURN_IF_ERROR(
      RequireField(beta > 0 && beta <= 1, "beta", beta, "in (0, 1]"));
  RETURN_IF_ERROR(RequireField(min_level_size >= 2, "min_level_size",
                               min_level_size, ">= 2"));
  return RequireField(solve_width == 0 || solve_width >= 2 * min_level_size,
                      "solve_width", solve_width,
                      "0 (the views' size) or >= 2 x min_level_size");
}

void to_json(nlohmann::json& j, const FattalOptions& o) {
  const auto& [alpha, beta, min_level_size, solve_width] = o;
  j = nlohmann::json{{"alpha", alpha},
                     {"beta", beta},
                     {"min_level_size", min_level_size},
                     {"solve_width", solve_width}};
}

absl::Status Params::Validate() const {
  RETURN_IF_ERROR(RequireField(saturation >= 0 && std::isfinite(saturation),
                               "saturation", saturation, ">= 0"));
  RETURN_IF_ERROR(
      RequireField(gamma > 0 && std::isfinite(gamma), "gamma", gamma, "> 0"));
  RETURN_IF_ERROR(
      RequireField(clip_low >= 0, "clip_low", clip_low, ">= 0 (a fraction)"));
  RETURN_IF_ERROR(RequireField(clip_high >= 0, "clip_high", clip_high,
                               ">= 0 (a fraction)"));
  RETURN_IF_ERROR(RequireField(clip_low + clip_high < 0.5,
                               "clip_low + clip_high", clip_low + clip_high,
                               "< 0.5"));
  RETURN_IF_ERROR(
      RequireField(base_contrast > 1 && std::isfinite(base_contrast),
                   "base_contrast", base_contrast, "> 1"));
  RETURN_IF_ERROR(WithFieldPrefix("reinhard", reinhard.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("drago", drago.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("durand", durand.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("fattal", fattal.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("guided", guided.Validate()));
  RETURN_IF_ERROR(
      WithFieldPrefix("domain_transform", domain_transform.Validate()));
  return WithFieldPrefix("wls", wls.Validate());
}

void to_json(nlohmann::json& j, const Params& o) {
  const auto& [saturation, gamma, clip_low, clip_high, base_contrast, reinhard,
               drago, durand, fattal, guided, domain_transform, wls] = o;
  j = nlohmann::json{{"saturation", saturation},
                     {"gamma", gamma},
                     {"clip_low", clip_low},
                     {"clip_high", clip_high},
                     {"base_contrast", base_contrast},
                     {"reinhard", reinhard},
                     {"drago", drago},
                     {"durand", durand},
                     {"fattal", fattal},
                     {"guided", guided},
                     {"domain_transform", domain_transform},
                     {"wls", wls}};
}

}  // namespace hdrstereo::tonemap
