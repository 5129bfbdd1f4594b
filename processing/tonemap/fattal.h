// SPDX-License-Identifier: GPL-3.0-or-later
//
// Building blocks of the Fattal operator, exposed for tests.
#ifndef HDRSTEREO_PROCESSING_TONEMAP_FATTAL_H_
#define HDRSTEREO_PROCESSING_TONEMAP_FATTAL_H_

#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::tonemap {

// Solves the 5-point Poisson equation lap(u) = f with Neumann (reflecting)
// boundary by DCT-II diagonalisation (even sizes; odd sizes by a DFT of the
// mirror extension), in double precision. f: CV_32FC1 or
// CV_64FC1. Returns the zero-mean solution as CV_64FC1. (The right-hand side
// of a Neumann problem must sum to zero; its mean is ignored.)
absl::StatusOr<cv::Mat> SolvePoissonNeumann(const cv::Mat& f);

// Fattal's gradient-domain compression of natural-log luminance for one or
// more views sharing statistics (each level's mean gradient magnitude is
// averaged over all views). Returns, per view, the reconstructed
// log-luminance (CV_32FC1), shifted so that input minus output has median
// zero over the mid-tones (pooled 40th..60th percentile of the input). With
// beta = 1 nothing is attenuated and the input is reproduced.
absl::StatusOr<std::vector<cv::Mat>> FattalCompress(
    const std::vector<cv::Mat>& log_lum, const FattalOptions& params);

}  // namespace hdrstereo::tonemap

#endif  // HDRSTEREO_PROCESSING_TONEMAP_FATTAL_H_
