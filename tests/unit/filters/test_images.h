// SPDX-License-Identifier: GPL-3.0-or-later
#ifndef HDRSTEREO_TESTS_UNIT_FILTERS_TEST_IMAGES_H_
#define HDRSTEREO_TESTS_UNIT_FILTERS_TEST_IMAGES_H_

#include <cmath>
#include <opencv2/core.hpp>

namespace hdrstereo::testing {

// Smooth shading + texture + noise + a few edges, values in [0, 1].
inline cv::Mat TestImage(int width, int height, int channels, int seed) {
  cv::RNG rng(seed);
  cv::Mat m(height, width, CV_32FC(channels));
  for (int y = 0; y < height; ++y) {
    float* p = m.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < channels; ++c) {
        double v = 0.3 + 0.2 * std::sin(0.05 * x + c) * std::cos(0.07 * y);
        if (x > width / 2) v += 0.3;
        if (y > 2 * height / 3 && x < width / 3) v -= 0.2;
        v += 0.05 * std::sin(1.3 * x + 0.7 * y);
        v += rng.gaussian(0.02);
        p[x * channels + c] =
            static_cast<float>(std::min(1.0, std::max(0.0, v)));
      }
    }
  }
  return m;
}

// Horizontal step: `low` left of column `edge`, `high` from it on.
inline cv::Mat StepImage(int width, int height, int edge, float low,
                         float high) {
  cv::Mat m(height, width, CV_32FC1, cv::Scalar(low));
  m.colRange(edge, width).setTo(high);
  return m;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_UNIT_FILTERS_TEST_IMAGES_H_
