// SPDX-License-Identifier: GPL-3.0-or-later
//
// Small islands of another surface's disparity, removed (docs/results.md,
// "Islands: speckles removed").
//
// Where every candidate fails on a surface, the graph cut and the
// photo-consistency choice leave islands of a few pixels that carry a
// disparity far from everything around them: on textured's box top, seen
// at a grazing angle (13 rows at 1200 px whose disparity climbs 3 px a
// row, where the fronto-parallel matcher has no right value), pixels take
// the wall's disparity 30 to 80 px away, and those few pixels dominate the
// RMSE. As semi-global matching's refinement removes peaks (Hirschmueller
// 2008, "removal of peaks"), 4-connected regions whose neighbours differ
// by at most max_step x tau are found (OpenCV's filterSpeckles, on the
// map in 1/16 px steps, so the step is max_step x tau within 1/16 px); a
// region of at most max_size pixels (at 320 px wide, times the area's
// scale; below about 72 px wide that is 0 and nothing is removed) is
// removed and filled along its row with the smaller of the nearest kept
// values to its left and right: the background, a simplification of how
// his discontinuity-preserving interpolation fills occlusions (the second
// lowest of 8 directions). On the scenes measured it was better than the
// cheapest other candidate everywhere and better than the candidate
// nearest the local mean on Cones, not on most simulated scenes (the doc
// has the numbers). max_step is a few tau, not one, so that a slanted
// surface whose disparity steps by 2 tau a row stays one region. A removed
// pixel with no kept value on its row keeps its value.
#ifndef HDRSTEREO_PROCESSING_FUSION_SPECKLES_H_
#define HDRSTEREO_PROCESSING_FUSION_SPECKLES_H_

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::fusion {

// Chosen on lab-lamp, two-lamps, desk-lamp and textured at 320, 640 and
// 1200 px and on Middlebury Cones, checked on checkerboard and shadowed
// (docs/results.md has the sweep).
struct SpeckleOptions {
  bool enabled = true;    // read by FuseByReliability
  double max_size = 10;   // pixels at 320 px wide; times (width / 320)^2
  double max_step = 3.0;  // in tau: neighbours closer are one region

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const SpeckleOptions& o);

struct SpeckleResult {
  cv::Mat disparity;             // CV_32FC1
  double replaced_fraction = 0;  // of the pixels: removed and filled
};

// `disparity`: CV_32FC1, at most 32767 px a side; values invalid by the
// fusion's rule (fusion.h: IsValidDisparity) are in no region and never
// changed. tau: the agreement tolerance in pixels of this size; max_disp:
// the largest disparity.
absl::StatusOr<SpeckleResult> RemoveSpeckles(const cv::Mat& disparity,
                                             double tau, int max_disp,
                                             const SpeckleOptions& options);

}  // namespace hdrstereo::fusion

#endif  // HDRSTEREO_PROCESSING_FUSION_SPECKLES_H_
