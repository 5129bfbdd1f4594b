// SPDX-License-Identifier: GPL-3.0-or-later
//
// Domain-transform edge-aware filter, recursive-filter variant (Gastal &
// Oliveira, SIGGRAPH 2011, Sec. 4 "RF"): OpenCV's cv::ximgproc DTFilter
// (DTF_RF) behind the filters' checks and options.
//
// The guide J defines the 1-D domain transform ct(u) = integral of
// 1 + sigma_s / sigma_r * sum_c |J_c'| (L1 over channels); the input is
// smoothed by a first-order recursive filter along rows then columns,
// `iterations` times, with a per-iteration spatial sigma
// sigma_H_i = sigma_s * sqrt(3) * 2^(N - i) / sqrt(4^N - 1), i = 1..N, so the
// composite filter has spatial standard deviation sigma_s. The feedback
// coefficient between neighbours is a^d with a = exp(-sqrt(2) / sigma_H_i)
// and d their distance in the transformed domain. sigma_r is in guide units
// (Gastal's code assumes guides in [0, 1]).
#ifndef HDRSTEREO_PROCESSING_FILTERS_DOMAIN_TRANSFORM_H_
#define HDRSTEREO_PROCESSING_FILTERS_DOMAIN_TRANSFORM_H_

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::filters {

struct DomainTransformOptions {
  // OpenCV's filter silently raises smaller values to these minimums, so
  // Validate rejects them instead.
  static constexpr double kMinSigmaS = 1.0;
  static constexpr double kMinSigmaR = 0.01;

  double sigma_s = 60.0;  // spatial standard deviation, pixels, >= 1
  double sigma_r = 0.33;  // range standard deviation, guide units, >= 0.01
  int iterations = 3;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const DomainTransformOptions& o);

// src: CV_8U or CV_32F, any number of channels; guide: same size, 1 or 3
// channels, or empty to use src (then 1 or 3 channels). Returns CV_32F with
// src's channels.
absl::StatusOr<cv::Mat> DomainTransformFilter(
    const cv::Mat& src, const cv::Mat& guide,
    const DomainTransformOptions& options = {});

}  // namespace hdrstereo::filters

#endif  // HDRSTEREO_PROCESSING_FILTERS_DOMAIN_TRANSFORM_H_
