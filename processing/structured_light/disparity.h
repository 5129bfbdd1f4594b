// SPDX-License-Identifier: GPL-3.0-or-later
//
// Disparities from decoded structured light on rectified views (Scharstein &
// Szeliski 2003; thesis 4.2.1):
//   - sub-pixel codes: along each scanline the decoded projector column and
//     row are quantised steps; a local least-squares line through the codes
//     of one surface (a run of neighbouring pixels whose codes change
//     smoothly) gives a continuous code at every pixel, i.e. the centre of
//     each code region rather than its integer label;
//   - view disparity: a left pixel matches the right pixel position on the
//     same scanline where the right continuous column equals its own (linear
//     interpolation between neighbouring right pixels) and the rows agree;
//     the same from right to left, then a left-right consistency check;
//   - illumination disparity: the projector is a third "camera" whose 3x4
//     matrix maps disparity space (x, y, d, 1) of the left view to projector
//     (column, row, 1). It is estimated by robust DLT (RANSAC, then
//     iteratively reweighted linear refinement) from pixels with a view
//     disparity, and then gives a disparity for any pixel with a code, even
//     where the other view has no match.
#ifndef HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_DISPARITY_H_
#define HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_DISPARITY_H_

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "processing/structured_light/decode.h"

namespace hdrstereo::structured_light {

struct MatchOptions {
  // Disparity search range in pixels (left x - right x); max 0 = width.
  int min_disparity = 0;
  int max_disparity = 0;
  // Half-window of the line fitted through the codes along a scanline.
  int fit_radius = 2;
  // Neighbouring pixels belong to one surface when their projector column
  // and row differ by at most this many projector pixels (plus the width
  // of a coarse code, DecodeOptions::min_bits, less one).
  int max_code_step = 8;
  // A match needs the projector rows to agree within this many rows.
  double max_row_difference = 1.5;
  // Left-right check tolerance in pixels.
  double lr_tolerance = 1.0;
};

// Continuous projector coordinates per pixel (CV_32FC1, NaN = invalid).
struct SubpixelCodes {
  cv::Mat column;
  cv::Mat row;
  // CV_32FC1: half the range of projector rows a pixel's row code stands
  // for beyond one row (0 for full codes; 3.5 for a code 8 rows wide). Rows
  // of two views agree when they differ by at most max_row_difference plus
  // both half-widths. Empty = 0 everywhere.
  cv::Mat row_halfwidth;
};

SubpixelCodes ComputeSubpixelCodes(const DecodedView& view,
                                   const MatchOptions& options = {});

// Disparity maps are CV_32FC1 in pixels, +inf where unknown (Middlebury):
// left: x_right = x - d; right: x_left = x + d.
struct ViewDisparity {
  cv::Mat left;
  cv::Mat right;
  int left_matched = 0;  // before the left-right check
  int right_matched = 0;
  int left_rejected = 0;  // removed by the left-right check
  int right_rejected = 0;
};

// INVALID_ARGUMENT when the views differ in size or are not decoded.
absl::StatusOr<ViewDisparity> ComputeViewDisparity(
    const SubpixelCodes& left, const SubpixelCodes& right,
    const MatchOptions& options = {});

struct ProjectorFitOptions {
  int max_samples = 20000;  // pixels used (evenly subsampled)
  int ransac_iterations = 300;
  double inlier_px = 1.0;  // reprojection error for RANSAC inliers
  uint64_t seed = 1;
};

struct ProjectorMatrix {
  // (x, y, d, 1) of a left pixel -> projector (column, row, 1) up to scale.
  cv::Matx34d left;
  // The same for the right view: (x, y, d, 1) with x_left = x + d.
  cv::Matx34d right;
  int samples = 0;
  int inliers = 0;
  double rms_px = 0;  // reprojection RMS over the inliers, projector pixels
};

// FAILED_PRECONDITION when fewer than 12 pixels have a disparity and a code
// or no consistent matrix is found.
absl::StatusOr<ProjectorMatrix> EstimateProjectorMatrix(
    const SubpixelCodes& left, const cv::Mat& left_disparity,
    const ProjectorFitOptions& options = {});

// Disparity of every pixel with a code from the projector matrix `p` of its
// view (ProjectorMatrix::left or ::right); +inf where the code is invalid,
// the solution is outside [min_d, max_d] or it reprojects worse than
// `max_residual_px`.
cv::Mat IlluminationDisparity(const SubpixelCodes& codes, const cv::Matx34d& p,
                              double min_d, double max_d,
                              double max_residual_px = 1.0);

}  // namespace hdrstereo::structured_light

#endif  // HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_DISPARITY_H_
