// SPDX-License-Identifier: GPL-3.0-or-later
//
// StereoOptions' rules and canonical JSON.
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/stereo/cost_volume_stereo.h"

namespace hdrstereo::stereo {
namespace {

const char* CostModeName(CostMode mode) {
  switch (mode) {
    case CostMode::kLdr:
      return "ldr";
    case CostMode::kHdrLogLuminance:
      return "hdr_log_luminance";
    case CostMode::kHdrRadianceGradient:
      return "hdr_radiance_gradient";
  }
  return "unknown";
}

}  // namespace

absl::Status StereoOptions::Validate() const {
  if (max_disparity <= min_disparity) {
    return absl::InvalidArgumentError(absl::StrCat(
        "max_disparity is ", max_disparity,
        "; it must be greater than min_disparity (", min_disparity, ")"));
  }
  RETURN_IF_ERROR(RequireField(alpha >= 0 && alpha <= 1, "alpha", alpha,
                               "in [0, 1] (cost weight of colour)"));
  RETURN_IF_ERROR(RequireField(tau_color > 0, "tau_color", tau_color, "> 0"));
  RETURN_IF_ERROR(
      RequireField(tau_gradient > 0, "tau_gradient", tau_gradient, "> 0"));
  RETURN_IF_ERROR(
      RequireField(radius >= 1, "radius", radius, ">= 1 (guided filter)"));
  RETURN_IF_ERROR(RequireField(eps > 0 && std::isfinite(eps), "eps", eps,
                               "> 0 (guided filter)"));
  RETURN_IF_ERROR(
      RequireField(lr_tolerance >= 0, "lr_tolerance", lr_tolerance, ">= 0"));
  if (weighted_median) {
    RETURN_IF_ERROR(RequireField(median_radius >= 1, "median_radius",
                                 median_radius, ">= 1 (weighted median)"));
    RETURN_IF_ERROR(
        RequireField(sigma_s > 0, "sigma_s", sigma_s, "> 0 (weighted median)"));
    RETURN_IF_ERROR(
        RequireField(sigma_c > 0, "sigma_c", sigma_c, "> 0 (weighted median)"));
  }
  RETURN_IF_ERROR(RequireField(
      hdr_white_percentile >= 0 && hdr_white_percentile <= 100,
      "hdr_white_percentile", hdr_white_percentile, "in [0, 100]"));
  return RequireField(threads >= 0, "threads", threads,
                      ">= 0 (0 = OpenCV's thread count)");
}

void to_json(nlohmann::json& j, const StereoOptions& o) {
  const auto& [min_disparity, max_disparity, mode, alpha, tau_color,
               tau_gradient, radius, eps, left_right_check, lr_tolerance, fill,
               weighted_median, median_radius, sigma_s, sigma_c, subpixel,
               gain_compensation, hdr_white_percentile, threads] = o;
  j = nlohmann::json{{"min_disparity", min_disparity},
                     {"max_disparity", max_disparity},
                     {"mode", CostModeName(mode)},
                     {"alpha", alpha},
                     {"tau_color", tau_color},
                     {"tau_gradient", tau_gradient},
                     {"radius", radius},
                     {"eps", eps},
                     {"left_right_check", left_right_check},
                     {"lr_tolerance", lr_tolerance},
                     {"fill", fill},
                     {"weighted_median", weighted_median},
                     {"median_radius", median_radius},
                     {"sigma_s", sigma_s},
                     {"sigma_c", sigma_c},
                     {"subpixel", subpixel},
                     {"gain_compensation", gain_compensation},
                     {"hdr_white_percentile", hdr_white_percentile},
                     {"threads", threads}};
}

}  // namespace hdrstereo::stereo
