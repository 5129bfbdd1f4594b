// SPDX-License-Identifier: GPL-3.0-or-later
//
// Exact ground truth for a stereo pair taken with the stage at `left_mm`
// (left view) and `left_mm + baseline_mm` (right view): noise-free radiance,
// depth, disparity and non-occlusion masks, computed by ray casting.
//
// Disparity of a left pixel (u, v) whose surface point projects to (u', v')
// in the right view is u - u' (positive); for an ideal rig v' == v and
// u - u' = f * B / Z exactly. For a misaligned rig the same x difference is
// given, and the y difference as well (images are then not rectified).
// Pixels that see nothing have +inf disparity and depth (Middlebury style).
#ifndef HDRSTEREO_HARDWARE_SIM_TRUTH_H_
#define HDRSTEREO_HARDWARE_SIM_TRUTH_H_

#include <filesystem>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "hardware/sim/render.h"

namespace hdrstereo::sim {

struct ViewTruth {
  cv::Mat radiance;     // CV_32FC3, BGR, cd/m^2
  cv::Mat depth;        // CV_32FC1, z-depth in mm, +inf = nothing hit
  cv::Mat disparity;    // CV_32FC1, |u_this - u_other| in px, +inf = none
  cv::Mat disparity_y;  // CV_32FC1, v_other - v_this (0 for an ideal rig)
  // CV_8UC1: 255 where the surface point is also visible in the other view
  // (inside its image and not hidden), 0 for occluded / out of view / empty.
  cv::Mat nonoccluded;
  cv::Mat object_id;  // CV_16UC1 as in RadianceFrame
};

struct StereoTruth {
  double left_mm = 0;
  double baseline_mm = 0;
  bool rectified = true;  // ideal rig: disparity_y is 0 everywhere
  CameraIntrinsics intrinsics;
  ViewTruth left;
  ViewTruth right;
};

// `projector_pattern` as in Renderer::Render (empty = projector off).
absl::StatusOr<StereoTruth> ComputeStereoTruth(
    const Renderer& renderer, double left_mm, double baseline_mm,
    const cv::Mat& projector_pattern = cv::Mat());

// Writes radiance{0,1}.pfm, depth{0,1}.pfm, disp{0,1}.pfm (0 = left,
// 1 = right), nonocc{0,1}.png and a Middlebury calib.txt
// (processing/io/middlebury.h, with the extra key left_stage_mm) into `dir`
// (created if missing), each file atomically; for a misaligned rig also
// dispy{0,1}.pfm (the vertical component).
absl::Status WriteStereoTruth(const StereoTruth& truth,
                              const std::filesystem::path& dir);

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_TRUTH_H_
