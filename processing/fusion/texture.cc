// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/texture.h"

#include <opencv2/imgproc.hpp>

namespace hdrstereo::fusion {

cv::Mat GradientMagnitude(const cv::Mat& view) {
  cv::Mat gray, dx, dy, magnitude;
  if (view.channels() == 3) {
    cv::cvtColor(view, gray, cv::COLOR_BGR2GRAY);
  } else {
    gray = view;
  }
  cv::Sobel(gray, dx, CV_32F, 1, 0);
  cv::Sobel(gray, dy, CV_32F, 0, 1);
  cv::magnitude(dx, dy, magnitude);
  return magnitude * (1.0 / 8.0);
}

}  // namespace hdrstereo::fusion
