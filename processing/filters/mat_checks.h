// SPDX-License-Identifier: GPL-3.0-or-later
//
// Input validation shared by the filters (internal to processing/).
#ifndef HDRSTEREO_PROCESSING_FILTERS_MAT_CHECKS_H_
#define HDRSTEREO_PROCESSING_FILTERS_MAT_CHECKS_H_

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::filters {

// OK when `m` is non-empty, 2-D, of depth CV_8U or CV_32F (or only CV_32F
// when `float_only`), has one of `channels` (0 = any) and no NaN/Inf.
absl::Status CheckImage(const cv::Mat& m, absl::string_view what,
                        bool float_only, std::initializer_list<int> channels);

// Converts to CV_32F (no scaling); shares data when already float.
cv::Mat ToFloat(const cv::Mat& m);

}  // namespace hdrstereo::filters

#endif  // HDRSTEREO_PROCESSING_FILTERS_MAT_CHECKS_H_
