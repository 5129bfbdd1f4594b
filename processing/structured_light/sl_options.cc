// SPDX-License-Identifier: GPL-3.0-or-later
//
// The structured-light options' rules and canonical JSON.
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/disparity.h"
#include "processing/structured_light/ground_truth.h"

namespace hdrstereo::structured_light {
namespace {

// A fraction of full scale in [0, 1].
absl::Status RequireFraction(double value, const char* field) {
  return RequireField(value >= 0 && value <= 1, field, value,
                      "in [0, 1] (a fraction of full scale)");
}

}  // namespace

absl::Status DecodeOptions::Validate() const {
  RETURN_IF_ERROR(RequireFraction(min_contrast, "min_contrast"));
  RETURN_IF_ERROR(
      RequireFraction(min_relative_contrast, "min_relative_contrast"));
  RETURN_IF_ERROR(RequireField(min_bits >= 0, "min_bits", min_bits,
                               ">= 0 (0 = every bit must count)"));
  RETURN_IF_ERROR(RequireFraction(min_lit, "min_lit"));
  return RequireField(saturation > 0 && saturation <= 1, "saturation",
                      saturation, "in (0, 1] (a fraction of full scale)");
}

void to_json(nlohmann::json& j, const DecodeOptions& o) {
  const auto& [min_contrast, min_relative_contrast, min_bits, min_lit,
               saturation] = o;
  j = nlohmann::json{{"min_contrast", min_contrast},
                     {"min_relative_contrast", min_relative_contrast},
                     {"min_bits", min_bits},
                     {"min_lit", min_lit},
                     {"saturation", saturation}};
}

absl::Status MatchOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(max_disparity >= 0, "max_disparity",
                               max_disparity, ">= 0 (0 = the image width)"));
  if (max_disparity > 0 && max_disparity <= min_disparity) {
    return absl::InvalidArgumentError(
        absl::StrCat("max_disparity is ", max_disparity,
                     "; it must be greater than min_disparity (", min_disparity,
                     ") or 0 (the image width)"));
  }
  RETURN_IF_ERROR(
      RequireField(fit_radius >= 1, "fit_radius", fit_radius, ">= 1"));
  RETURN_IF_ERROR(RequireField(max_code_step >= 1, "max_code_step",
                               max_code_step, ">= 1 (projector pixels)"));
  RETURN_IF_ERROR(RequireField(max_row_difference >= 0, "max_row_difference",
                               max_row_difference, ">= 0 (projector rows)"));
  return RequireField(lr_tolerance >= 0, "lr_tolerance", lr_tolerance,
                      ">= 0 (px)");
}

void to_json(nlohmann::json& j, const MatchOptions& o) {
  const auto& [min_disparity, max_disparity, fit_radius, max_code_step,
               max_row_difference, lr_tolerance] = o;
  j = nlohmann::json{{"min_disparity", min_disparity},
                     {"max_disparity", max_disparity},
                     {"fit_radius", fit_radius},
                     {"max_code_step", max_code_step},
                     {"max_row_difference", max_row_difference},
                     {"lr_tolerance", lr_tolerance}};
}

absl::Status ProjectorFitOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(max_samples >= 12, "max_samples", max_samples,
                               ">= 12 (the fit needs 12 pixels)"));
  RETURN_IF_ERROR(RequireField(ransac_iterations >= 1, "ransac_iterations",
                               ransac_iterations, ">= 1"));
  return RequireField(inlier_px > 0, "inlier_px", inlier_px,
                      "> 0 (projector pixels)");
}

void to_json(nlohmann::json& j, const ProjectorFitOptions& o) {
  const auto& [max_samples, ransac_iterations, inlier_px, seed] = o;
  j = nlohmann::json{{"max_samples", max_samples},
                     {"ransac_iterations", ransac_iterations},
                     {"inlier_px", inlier_px},
                     {"seed", seed}};
}

absl::Status GroundTruthOptions::Validate() const {
  RETURN_IF_ERROR(WithFieldPrefix("match", match.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("projector", projector.Validate()));
  RETURN_IF_ERROR(RequireField(consistency_px >= 0, "consistency_px",
                               consistency_px, ">= 0 (px)"));
  RETURN_IF_ERROR(RequireField(
      max_illumination_residual_px > 0, "max_illumination_residual_px",
      max_illumination_residual_px, "> 0 (projector pixels)"));
  RETURN_IF_ERROR(RequireField(max_hole_area >= 0, "max_hole_area",
                               max_hole_area, ">= 0 (pixels; 0 = no filling)"));
  return RequireField(max_fill_range >= 0, "max_fill_range", max_fill_range,
                      ">= 0 (px)");
}

void to_json(nlohmann::json& j, const GroundTruthOptions& o) {
  const auto& [match, projector, use_illumination, consistency_px,
               max_illumination_residual_px, max_hole_area, max_fill_range] = o;
  j = nlohmann::json{
      {"match", match},
      {"projector", projector},
      {"use_illumination", use_illumination},
      {"consistency_px", consistency_px},
      {"max_illumination_residual_px", max_illumination_residual_px},
      {"max_hole_area", max_hole_area},
      {"max_fill_range", max_fill_range}};
}

}  // namespace hdrstereo::structured_light
