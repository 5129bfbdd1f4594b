// SPDX-License-Identifier: GPL-3.0-or-later
//
// Structured-light ground truth for a rectified stereo pair (thesis 4.2;
// Scharstein & Szeliski 2003), from two decoded views:
//   1. view disparities with left-right check (disparity.h);
//   2. the projector's 3x4 matrix by robust DLT and illumination disparities
//      for every pixel with a code; where both exist they must agree within
//      `consistency_px` (else the pixel is invalid), where only the
//      illumination disparity exists it fills in (e.g. pixels the other
//      camera does not see);
//   3. post-processing: small holes of lit pixels whose border lies on one
//      surface and does not touch an unlit pixel are interpolated; holes the
//      projector never lit and large or depth-discontinuous holes stay invalid
//      and are counted, never invented.
// Output in Middlebury layout: disp0GT.pfm, disp1GT.pfm (+inf unknown),
// mask0nocc.png (255 non-occluded, 128 occluded, 0 unknown).
#ifndef HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_GROUND_TRUTH_H_
#define HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_GROUND_TRUTH_H_

#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/disparity.h"

namespace hdrstereo::structured_light {

struct GroundTruthOptions {
  MatchOptions match;
  ProjectorFitOptions projector;
  bool use_illumination = true;
  // View and illumination disparities must agree within this (pixels).
  double consistency_px = 1.0;
  // Illumination disparities must reproject within this (projector px).
  double max_illumination_residual_px = 1.0;
  // Holes of lit pixels up to this area (pixels, 8-connected) are filled
  // when the disparities around them span at most `max_fill_range` px.
  int max_hole_area = 25;
  double max_fill_range = 2.0;

  // INVALID_ARGUMENT naming the first field that breaks a rule, nested
  // fields with their path ("match.fit_radius is 0; ...").
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const GroundTruthOptions& o);

struct ViewStats {
  int pixels = 0;
  int lit = 0;                     // white - black passed (decode)
  int decoded = 0;                 // projector column and row known
  int view_matched = 0;            // view disparity after the left-right check
  int lr_rejected = 0;             // removed by the left-right check
  int illumination_only = 0;       // filled by the illumination disparity
  int agree = 0;                   // view and illumination both, consistent
  int inconsistent = 0;            // view and illumination disagree: invalid
  double mean_abs_difference = 0;  // |view - illumination| where they agree
  int hole_filled = 0;             // small holes interpolated
  int holes_left = 0;              // lit holes too large / across an edge
  int hole_pixels_left = 0;
  int unlit_regions = 0;       // unlit regions >= max_hole_area (shadows)
  int unlit_pixels = 0;        // never lit: invalid by design
  int valid = 0;               // final disparities
  double coverage_of_lit = 0;  // valid lit pixels / lit pixels
};

struct GroundTruthStats {
  ViewStats view[2];    // 0 = left, 1 = right
  int nonoccluded = 0;  // mask0nocc == 255
  int occluded = 0;     // mask0nocc == 128
  bool projector_fitted = false;
  int projector_samples = 0;
  int projector_inliers = 0;
  double projector_rms_px = 0;
};

struct GroundTruth {
  cv::Mat disp0;      // CV_32FC1 left disparity, +inf unknown
  cv::Mat disp1;      // CV_32FC1 right disparity, +inf unknown
  cv::Mat mask0nocc;  // CV_8UC1 255 / 128 / 0
  std::optional<ProjectorMatrix> projector;
  GroundTruthStats stats;
  std::vector<std::string> warnings;
};

// INVALID_ARGUMENT when the views differ in size. A pair without any match
// gives all-invalid maps and a warning.
absl::StatusOr<GroundTruth> ComputeGroundTruth(
    const DecodedView& left, const DecodedView& right,
    const GroundTruthOptions& options = {});

// The statistics as a JSON object (stable keys, for reports and tests).
std::string StatsJson(const GroundTruthStats& stats);

// The statistics' file beside the Middlebury files.
inline constexpr char kStatsFile[] = "sl_stats.json";

// Writes the Middlebury ground truth (processing/io/middlebury.h:
// disp0GT.pfm, disp1GT.pfm, mask0nocc.png) and sl_stats.json into `dir`
// (created if missing), each atomically.
absl::Status WriteMiddlebury(const GroundTruth& truth,
                             const std::filesystem::path& dir);

}  // namespace hdrstereo::structured_light

#endif  // HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_GROUND_TRUTH_H_
