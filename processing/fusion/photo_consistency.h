// SPDX-License-Identifier: GPL-3.0-or-later
//
// On textured surfaces, the candidate the views agree with best
// (docs/results.md, "Depth edges: the views decide").
//
// Every candidate comes from the same matcher, whose aggregation window
// (a guided filter of radius 9 at 320 px) blurs depth edges; the candidates
// differ in where they put an edge, and the graph cut, weighing them by
// agreement, follows the majority there (textured at 640 px: 88 % of the
// fused map's squared error lies within 2 px of a depth edge of the truth,
// where Drago alone is better than the fused map). Fusion moves (Lempitsky,
// Rother, Roth & Blake 2010) choose between proposals by their matching
// cost; here each pixel's fused value and the candidates' values at that
// pixel that at least min_agreeing candidates (itself included) share
// within tau are the proposals, and the cost is adaptive support weight
// matching (Yoon & Kweon 2006) in a small window of a tone-mapped pair,
// whose weights follow the left view's colour edges, so a window on a
// depth edge looks at the pixel's own side of it. A value no other
// candidate shares is not proposed: on Middlebury Cones (real noise, fine
// repeated texture) such lone values won on cost where they were wrong,
// and the fused map got worse (1.154 -> 1.233 px).
//
// Cost of a value at pixel p, d = the value rounded to an integer:
//   C(p, d) = sum_q w(p, q) min(|L(q) - R(q - d)|, truncation) / sum_q w,
//   w(p, q) = exp(-|L(q) - L(p)| / colour_sigma - |q - p| / r),
// |.| of colours: the sum over channels (the cost: their mean), values in
// [0, 1]; q over the (2r + 1)^2 window inside the image whose partner
// q - d is inside the right view. Where the left view has texture (mean
// gradient in the window >= min_texture), a candidate whose cost is below
// max_cost_ratio x the fused value's replaces it (the first such candidate
// of a label; the cheapest label wins). Where the fused value has no
// partner in the right view, or costs 0, it is kept. Without texture a
// small window has no evidence; the plane prior (plane_prior.h) covers
// those surfaces. Values outside [0, max_disp + 0.5] (what the graph cut
// accepts) are never proposed nor replaced.
#ifndef HDRSTEREO_PROCESSING_FUSION_PHOTO_CONSISTENCY_H_
#define HDRSTEREO_PROCESSING_FUSION_PHOTO_CONSISTENCY_H_

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::fusion {

// Chosen on lab-lamp, two-lamps, desk-lamp and textured at 320, 640 and
// 1200 px and on Middlebury Cones, checked on checkerboard and shadowed
// (docs/results.md has the sweep). window_radius is at 320 px wide and
// scales with the width.
struct PhotoConsistencyOptions {
  bool enabled = true;          // read by FuseByReliability
  int window_radius = 1;        // at 320 px; r = round(radius x width / 320)
  double colour_sigma = 0.1;    // support weights, on [0, 1] values
  double truncation = 0.1;      // per-pixel cost cap, on [0, 1] values
  double min_texture = 4.0;     // grey levels per pixel (Sobel / 8)
  double max_cost_ratio = 0.9;  // of the fused value's cost
  int min_agreeing = 2;         // candidates within tau, itself included

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const PhotoConsistencyOptions& o);

struct PhotoConsistencyResult {
  cv::Mat disparity;             // CV_32FC1
  double replaced_fraction = 0;  // of the pixels
};

// `disparity` and `candidates`: CV_32FC1 (NaN: none); `left`, `right`: a
// pair of 8-bit views, 1 or 3 channels, the left one `disparity`'s view;
// all one size. tau: the agreement tolerance in pixels of this size;
// max_disp: the largest disparity.
absl::StatusOr<PhotoConsistencyResult> ChooseByPhotoConsistency(
    const cv::Mat& disparity, const std::vector<cv::Mat>& candidates,
    const cv::Mat& left, const cv::Mat& right, double tau, int max_disp,
    const PhotoConsistencyOptions& options);

}  // namespace hdrstereo::fusion

#endif  // HDRSTEREO_PROCESSING_FUSION_PHOTO_CONSISTENCY_H_
