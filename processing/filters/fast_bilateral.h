// SPDX-License-Identifier: GPL-3.0-or-later
//
// Fast bilateral filter by piecewise-linear range approximation with spatial
// downsampling (Durand & Dorsey, SIGGRAPH 2002, Sec. 5.1), the filter of the
// Durand tone-mapping operator.
//
// The range [min, max] of the input is cut into K segments of width <=
// sigma_r. For each segment value i_j, on the input downsampled by `ds`
// (INTER_AREA): G_j = exp(-(I - i_j)^2 / 2 sigma_r^2), H_j = G_j I, both
// Gaussian-blurred with sigma_s / ds, J_j = H_j / G_j. Every full-resolution
// pixel then interpolates linearly between the two J_j whose i_j bracket its
// value, each sampled bilinearly. Cost is K Gaussian blurs at 1/ds^2 size,
// independent of sigma_s. Our own code; not cv::bilateralFilter and not the
// (non-free, disabled) xphoto Durand operator.
#ifndef HDRSTEREO_PROCESSING_FILTERS_FAST_BILATERAL_H_
#define HDRSTEREO_PROCESSING_FILTERS_FAST_BILATERAL_H_

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"

namespace hdrstereo::filters {

struct FastBilateralOptions {
  double sigma_s = 8.0;  // spatial sigma, full-resolution pixels
  double sigma_r = 0.4;  // range sigma, input units
  int downsample = 0;    // 0 = automatic: max(1, floor(sigma_s / 2))
};

// src: CV_32FC1 (or CV_8UC1), finite. Returns CV_32FC1.
absl::StatusOr<cv::Mat> FastBilateralFilter(
    const cv::Mat& src, const FastBilateralOptions& options = {});

}  // namespace hdrstereo::filters

#endif  // HDRSTEREO_PROCESSING_FILTERS_FAST_BILATERAL_H_
