// SPDX-License-Identifier: GPL-3.0-or-later
//
// A synthetic HDR scene for tone-mapping tests and benchmarks: radiance
// 1 .. 8000 (BGR, linear) with a log ramp, a fine texture, a bright lamp
// disc, a 100:1 step edge and coloured regions.
#ifndef HDRSTEREO_TESTS_UNIT_TONEMAP_SYNTHETIC_SCENE_H_
#define HDRSTEREO_TESTS_UNIT_TONEMAP_SYNTHETIC_SCENE_H_

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

namespace hdrstereo::testing {

// Radiance at scene coordinates (x, y) of a width x height view; x may lie
// outside [0, width) so shifted stereo views can be generated.
inline cv::Vec3f SceneRadiance(double x, double y, int width, int height) {
  const double u = x / width, v = y / height;
  // Log ramp 1 .. 100 across, a little vertical variation.
  double lum = std::pow(10.0, 2.0 * std::clamp(u, 0.0, 1.2)) * (1.0 + 0.3 * v);
  // Texture in the upper half.
  if (v < 0.5) {
    lum *= 1.0 +
           0.3 * std::sin(2 * CV_PI * x / 7.0) * std::sin(2 * CV_PI * y / 5.0);
  }
  // 100:1 step edge in a horizontal band.
  if (v > 0.6 && v < 0.85) lum = (u < 0.5) ? 5.0 : 500.0;
  // Lamp disc.
  const double dx = x - 0.75 * width, dy = y - 0.25 * height;
  const double radius = 0.08 * std::min(width, height);
  if (dx * dx + dy * dy < radius * radius) lum = 8000.0;
  lum = std::max(lum, 1.0);
  // Tints (B, G, R) by region; luminance weights sum to 1 for grey.
  cv::Vec3f tint =
      (u < 0.5) ? cv::Vec3f(0.8f, 1.0f, 1.25f) : cv::Vec3f(1.3f, 1.0f, 0.75f);
  if (v > 0.9) tint = cv::Vec3f(1.0f, 1.0f, 1.0f);
  const float l_tint =
      0.0722f * tint[0] + 0.7152f * tint[1] + 0.2126f * tint[2];
  const float k = static_cast<float>(lum) / l_tint;
  return cv::Vec3f(tint[0] * k, tint[1] * k, tint[2] * k);
}

// View whose pixel x shows scene column x + shift.
inline cv::Mat SyntheticScene(int width, int height, int shift = 0) {
  cv::Mat m(height, width, CV_32FC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      m.at<cv::Vec3f>(y, x) = SceneRadiance(x + shift, y, width, height);
    }
  }
  return m;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_UNIT_TONEMAP_SYNTHETIC_SCENE_H_
