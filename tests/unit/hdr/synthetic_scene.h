// SPDX-License-Identifier: GPL-3.0-or-later
//
// Exact synthetic truth for HDR tests and benchmarks: a known radiance map
// (1..8000 with a bright lamp and a tiny filament far beyond any exposure),
// a known S-shaped camera response and the thesis' eight exposure times.
// Rendering quantises to 8 bits with a little seeded noise.
#ifndef HDRSTEREO_TESTS_UNIT_HDR_SYNTHETIC_SCENE_H_
#define HDRSTEREO_TESTS_UNIT_HDR_SYNTHETIC_SCENE_H_

#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

namespace hdrstereo::testing {

// Thesis ch. 3: 1/15 s .. 1/2000 s.
inline std::vector<double> ThesisExposureTimes() {
  return {1.0 / 15,  1.0 / 30,  1.0 / 60,   1.0 / 125,
          1.0 / 250, 1.0 / 500, 1.0 / 1000, 1.0 / 2000};
}

// The true response: code = 255 * sigmoid(a * ln(k E dt / x0)), so the true
// inverse is g(z) = ln(E dt) = ln(x0 / k) + logit(z / 255) / a.
struct TrueResponse {
  double k = 0.2, x0 = 0.1, a = 1.2;
  double Code(double exposure) const {  // continuous code for E*dt
    const double s = 1.0 / (1.0 + std::pow(x0 / (k * exposure), a));
    return 255.0 * s;
  }
  double LogExposure(double code) const {  // g(z), continuous
    const double s = code / 255.0;
    return std::log(x0 / k) + std::log(s / (1.0 - s)) / a;
  }
};

// BGR radiance: a horizontal log ramp 0.5..~300 with texture, a Gaussian
// lamp peaking at 8000 and a 3x3 filament at 1e8 (clipped in every
// exposure).
inline cv::Mat SyntheticRadiance(int width, int height) {
  cv::Mat e(height, width, CV_32FC3);
  const cv::Vec3f tint(0.7f, 1.0f, 0.85f);
  const double lx = 0.7 * width, ly = 0.4 * height;
  const double r = std::max(4.0, 0.06 * width);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double ramp = std::exp(std::log(300.0) * x / (width - 1));
      const double tex = 1.0 + 0.3 * std::sin(0.37 * x) * std::cos(0.23 * y);
      const double d2 = ((x - lx) * (x - lx) + (y - ly) * (y - ly)) / (r * r);
      double v = std::max(0.72, ramp * tex) + 8000.0 * std::exp(-d2);
      if (std::abs(x - std::lround(lx)) <= 1 &&
          std::abs(y - std::lround(ly)) <= 1) {
        v = 1e8;
      }
      for (int c = 0; c < 3; ++c) {
        e.at<cv::Vec3f>(y, x)[c] = static_cast<float>(v * tint[c]);
      }
    }
  }
  return e;
}

// 8-bit exposures of `radiance` through `response`, with multiplicative
// Gaussian noise of relative sigma `noise` on the exposure before the
// response (seeded).
inline std::vector<cv::Mat> RenderExposures(const cv::Mat& radiance,
                                            const std::vector<double>& times,
                                            const TrueResponse& response,
                                            double noise, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise);
  std::vector<cv::Mat> out;
  for (double t : times) {
    cv::Mat img(radiance.size(), CV_8UC3);
    for (int y = 0; y < radiance.rows; ++y) {
      const float* src = radiance.ptr<float>(y);
      uint8_t* dst = img.ptr<uint8_t>(y);
      for (int i = 0; i < radiance.cols * 3; ++i) {
        const double x = src[i] * t * (1.0 + (noise > 0 ? gauss(rng) : 0.0));
        const double code = std::round(response.Code(std::max(x, 1e-12)));
        dst[i] = static_cast<uint8_t>(std::clamp(code, 0.0, 255.0));
      }
    }
    out.push_back(img);
  }
  return out;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_UNIT_HDR_SYNTHETIC_SCENE_H_
