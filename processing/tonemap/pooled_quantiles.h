// SPDX-License-Identifier: GPL-3.0-or-later
//
// Quantiles of the luminances of all views together, so that a stereo pair
// is tone-mapped with one scale (thesis 5.1: the views must stay comparable
// for matching).
#ifndef HDRSTEREO_PROCESSING_TONEMAP_POOLED_QUANTILES_H_
#define HDRSTEREO_PROCESSING_TONEMAP_POOLED_QUANTILES_H_

#include <opencv2/core.hpp>
#include <utility>
#include <vector>

namespace hdrstereo::tonemap {

// The values at quantiles `q_lo` <= `q_hi` (in [0, 1]) of the pooled
// CV_32F pixels of `mats`, sampled at every second pixel of every second
// row. `mats` must hold at least one pixel.
std::pair<float, float> PooledQuantiles(const std::vector<cv::Mat>& mats,
                                        double q_lo, double q_hi);

}  // namespace hdrstereo::tonemap

#endif  // HDRSTEREO_PROCESSING_TONEMAP_POOLED_QUANTILES_H_
