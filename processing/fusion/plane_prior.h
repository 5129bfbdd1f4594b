// SPDX-License-Identifier: GPL-3.0-or-later
//
// Surfaces without texture take a plane (docs/results.md, "Surfaces
// without texture").
//
// On a surface with no texture no matcher has evidence: each candidate
// returns what its aggregation window brings in from the surroundings, and
// several candidates can agree on the same wrong disparity (desk-lamp's
// box face, where Reinhard's and Drago's maps both carry the wall's), so no
// weighting of the candidates can find the right one. Segment-based stereo
// (Tao, Sawhney & Kumar 2001; Bleyer & Gelautz 2005; Klaus, Sormann &
// Karner 2006) models each colour segment as a plane fitted robustly to its
// reliable disparities. Here only segments without texture are replaced,
// and only when one plane explains most of their reliable pixels, so that
// textured surfaces, where the matchers do have evidence, keep the fused
// disparities, and a segment that spans a depth edge keeps them too.
//
// Segments: Felzenszwalb & Huttenlocher's graph segmentation (OpenCV
// ximgproc) of a view where dark surfaces are visible (a tone-mapped view;
// the LDR exposure leaves them near black). Texture: the segment's mean
// gradient magnitude inside (Sobel / 8: grey levels per pixel), border
// pixels excluded. Plane: RANSAC (Fischler & Bolles 1981) on the segment's
// reliable pixels, refitted by least squares to its inliers (within tau).
#ifndef HDRSTEREO_PROCESSING_FUSION_PLANE_PRIOR_H_
#define HDRSTEREO_PROCESSING_FUSION_PLANE_PRIOR_H_

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::fusion {

// Chosen on lab-lamp, two-lamps, desk-lamp and textured at 320, 640 and
// 1200 px and checked on checkerboard and shadowed at 640 px
// (docs/results.md has the sweep). segment_k and min_segment_pixels are at
// 320 px wide and scale with the width, not the area: scaled with the area,
// segments grew across depth edges (lab-lamp at 640 px 1.50 px RMSE
// against 1.24).
struct PlanePriorOptions {
  bool enabled = true;     // read by FuseByReliability, which calls the prior
  double segment_k = 300;  // Felzenszwalb-Huttenlocher k
  double segment_sigma = 0.5;   // their pre-smoothing, px (not scaled)
  int min_segment_pixels = 50;  // smaller segments are merged
  double max_texture = 2.0;     // grey levels per pixel; above: textured
  double min_support = 0.3;     // reliable pixels, fraction of the segment
  double min_inliers = 0.7;     // of them within tau of the plane
  int ransac_iterations = 200;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const PlanePriorOptions& o);

struct PlanePriorResult {
  cv::Mat disparity;             // CV_32FC1
  int segments = 0;              // in the view
  int planes = 0;                // segments that took a plane
  double replaced_fraction = 0;  // of the pixels
};

// `disparity`: CV_32FC1 (NaN: none); `reliable`: CV_8UC1, non-zero where
// the disparity is supported; `view`: CV_8UC1 or CV_8UC3; all one size.
// Plane values are clamped to [0, max_disp]. tau in pixels of this size.
absl::StatusOr<PlanePriorResult> ApplyPlanePrior(
    const cv::Mat& disparity, const cv::Mat& reliable, const cv::Mat& view,
    double tau, int max_disp, const PlanePriorOptions& options);

}  // namespace hdrstereo::fusion

#endif  // HDRSTEREO_PROCESSING_FUSION_PLANE_PRIOR_H_
