// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/fast_bilateral.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/status_matchers.h"
#include "tests/unit/filters/test_images.h"

namespace hdrstereo::filters {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::StepImage;
using ::hdrstereo::testing::TestImage;

// Brute-force Gaussian bilateral filter (truncated at 3 sigma_s).
cv::Mat BruteBilateral(const cv::Mat& in, double ss, double sr) {
  cv::Mat out(in.size(), CV_32FC1);
  const int r = static_cast<int>(std::ceil(3 * ss));
  for (int y = 0; y < in.rows; ++y) {
    for (int x = 0; x < in.cols; ++x) {
      const double c = in.at<float>(y, x);
      double num = 0, den = 0;
      for (int j = std::max(0, y - r); j <= std::min(in.rows - 1, y + r); ++j) {
        for (int i = std::max(0, x - r); i <= std::min(in.cols - 1, x + r);
             ++i) {
          const double v = in.at<float>(j, i);
          const double w = std::exp(-((i - x) * (i - x) + (j - y) * (j - y)) /
                                        (2 * ss * ss) -
                                    (v - c) * (v - c) / (2 * sr * sr));
          num += w * v;
          den += w;
        }
      }
      out.at<float>(y, x) = static_cast<float>(num / den);
    }
  }
  return out;
}

TEST(FastBilateralTest, ApproximatesBruteForceBilateral) {
  // log10-luminance-like data: 0 .. 2.5.
  const cv::Mat img = TestImage(96, 64, 1, 1) * 2.5;
  FastBilateralOptions o;
  o.sigma_s = 4.0;
  o.sigma_r = 0.4;
  absl::StatusOr<cv::Mat> fast = FastBilateralFilter(img, o);
  ASSERT_TRUE(fast.ok()) << fast.status();
  const cv::Mat ref = BruteBilateral(img, 4.0, 0.4);
  const double mean_diff = cv::norm(*fast, ref, cv::NORM_L1) / img.total();
  RecordProperty("mean_abs_diff", std::to_string(mean_diff));
  // Piecewise-linear range approximation + downsampling: mean error <= 0.02
  // (in units where sigma_r = 0.4).
  EXPECT_LE(mean_diff, 0.02);
}

TEST(FastBilateralTest, KeepsAStepEdge) {
  const cv::Mat step = StepImage(128, 32, 64, 1.0f, 3.0f);  // 2 decades
  FastBilateralOptions o;
  o.sigma_s = 10.0;
  absl::StatusOr<cv::Mat> out = FastBilateralFilter(step, o);
  ASSERT_TRUE(out.ok());
  EXPECT_LE(cv::norm(*out, step, cv::NORM_INF), 0.02);
}

TEST(FastBilateralTest, ConstantImageUnchanged) {
  const cv::Mat c(20, 30, CV_32FC1, cv::Scalar(1.5));
  absl::StatusOr<cv::Mat> out = FastBilateralFilter(c, {});
  ASSERT_TRUE(out.ok());
  EXPECT_LE(cv::norm(*out, c, cv::NORM_INF), 1e-6);
}

TEST(FastBilateralTest, RejectsBadInput) {
  EXPECT_THAT(FastBilateralFilter(cv::Mat(), {}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("bilateral input is empty")));
  EXPECT_THAT(
      FastBilateralFilter(TestImage(8, 8, 3, 1), {}),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr(
              "bilateral input has an unsupported number of channels (3)")));
  EXPECT_THAT(
      FastBilateralFilter(TestImage(8, 8, 1, 1), {0, 0.4, 0}),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr("bilateral needs sigma_s > 0, sigma_r > 0; got 0, 0.4")));
}

}  // namespace
}  // namespace hdrstereo::filters
