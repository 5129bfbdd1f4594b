// SPDX-License-Identifier: GPL-3.0-or-later
//
// How much texture a view has, as the fusion's last steps measure it: the
// plane prior (per segment) and the photo-consistency choice (per window).
#ifndef HDRSTEREO_PROCESSING_FUSION_TEXTURE_H_
#define HDRSTEREO_PROCESSING_FUSION_TEXTURE_H_

#include <opencv2/core.hpp>

namespace hdrstereo::fusion {

// Per pixel of an 8-bit view (1 or 3 channels, BGR), the grey level's
// gradient magnitude in grey levels per pixel (CV_32FC1): Sobel's
// magnitude / 8, its gain on a unit ramp.
cv::Mat GradientMagnitude(const cv::Mat& view);

}  // namespace hdrstereo::fusion

#endif  // HDRSTEREO_PROCESSING_FUSION_TEXTURE_H_
