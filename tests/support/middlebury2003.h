// SPDX-License-Identifier: GPL-3.0-or-later
//
// A Middlebury 2003 pair in the layout of ../shared/data/middlebury-2003-*
// (its README.md): im2.png left, im6.png right (8-bit BGR), disp2.png /
// disp6.png truth with disparity = value / 4 and 0 = unknown, x_right =
// x_left - d. The folder has no occlusion mask; the README defines the
// non-occluded pixels as those whose left truth d agrees with the right
// truth at x - d within 1 px. Scores use processing/eval with that mask.
#ifndef HDRSTEREO_TESTS_SUPPORT_MIDDLEBURY2003_H_
#define HDRSTEREO_TESTS_SUPPORT_MIDDLEBURY2003_H_

#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"

namespace hdrstereo::testing {

struct Middlebury2003 {
  cv::Mat left, right;  // CV_8UC3
  cv::Mat truth;        // CV_32FC1 left disparity, 0 = unknown
  cv::Mat known;        // CV_8UC1, 255 where the left truth is known
  cv::Mat nonoccluded;  // CV_8UC1, 255 where known and not occluded
};

// The Cones folder, whether or not it exists.
inline std::filesystem::path ConesDir() {
  return std::filesystem::path(HDRSTEREO_SHARED_DIR) / "data" /
         "middlebury-2003-cones-quarter";
}

inline absl::StatusOr<Middlebury2003> LoadMiddlebury2003(
    const std::filesystem::path& dir) {
  Middlebury2003 m;
  m.left = cv::imread((dir / "im2.png").string(), cv::IMREAD_COLOR);
  m.right = cv::imread((dir / "im6.png").string(), cv::IMREAD_COLOR);
  const cv::Mat gl =
      cv::imread((dir / "disp2.png").string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat gr =
      cv::imread((dir / "disp6.png").string(), cv::IMREAD_GRAYSCALE);
  if (m.left.empty() || m.right.empty() || gl.empty() || gr.empty()) {
    return absl::NotFoundError(
        absl::StrCat("Middlebury 2003 files missing in ", dir.string()));
  }
  gl.convertTo(m.truth, CV_32F, 0.25);
  m.known = gl > 0;
  m.nonoccluded = cv::Mat::zeros(gl.size(), CV_8UC1);
  for (int y = 0; y < gl.rows; ++y) {
    for (int x = 0; x < gl.cols; ++x) {
      if (!gl.at<uchar>(y, x)) continue;
      const float d = m.truth.at<float>(y, x);
      const int xr = x - static_cast<int>(std::lround(d));
      if (xr < 0 || !gr.at<uchar>(y, xr)) continue;
      if (std::abs(0.25f * gr.at<uchar>(y, xr) - d) <= 1.0f) {
        m.nonoccluded.at<uchar>(y, x) = 255;
      }
    }
  }
  return m;
}

// An 8-bit view as linear radiance with an sRGB-like gamma 2.2 (Cones is
// one exposure; its camera response is not known): CV_32FC3 in [0, 1].
inline cv::Mat LinearisedWithGamma22(const cv::Mat& bgr8) {
  cv::Mat f;
  bgr8.convertTo(f, CV_32FC3, 1.0 / 255);
  cv::pow(f, 2.2, f);
  return f;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_MIDDLEBURY2003_H_
