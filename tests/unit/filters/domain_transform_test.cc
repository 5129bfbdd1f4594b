// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/domain_transform.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/ximgproc/edge_filter.hpp>

#include "tests/support/status_matchers.h"
#include "tests/unit/filters/test_images.h"

namespace hdrstereo::filters {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::StepImage;
using ::hdrstereo::testing::TestImage;

TEST(DomainTransformTest, ConstantImageUnchanged) {
  const cv::Mat c(48, 64, CV_32FC1, cv::Scalar(0.42));
  absl::StatusOr<cv::Mat> out = DomainTransformFilter(c, cv::Mat(), {});
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_LE(cv::norm(*out, c, cv::NORM_INF), 1e-5);
}

TEST(DomainTransformTest, KeepsAStepEdge) {
  const cv::Mat step = StepImage(128, 32, 64, 0.2f, 0.8f);
  absl::StatusOr<cv::Mat> out = DomainTransformFilter(step, cv::Mat(), {});
  ASSERT_TRUE(out.ok());
  // Across the edge the transformed distance is 1 + 60/0.33*0.6 ~ 110 pixels
  // of 60-sigma smoothing, so a little leaks (a^110 ~ 0.05 per pass at the
  // first iteration): measured 0.02, bound 0.03 (5 % of the step).
  EXPECT_LE(cv::norm(*out, step, cv::NORM_INF), 0.03);
}

TEST(DomainTransformTest, SmoothsFlatNoise) {
  cv::Mat noise(128, 128, CV_32FC1);
  cv::RNG(3).fill(noise, cv::RNG::NORMAL, 0.5, 0.005);
  absl::StatusOr<cv::Mat> out = DomainTransformFilter(noise, cv::Mat(), {});
  ASSERT_TRUE(out.ok());
  cv::Scalar mean, sd;
  cv::meanStdDev(*out, mean, sd);
  EXPECT_LT(sd[0], 0.005 / 5);
}

// OpenCV's dtFilter (DTF_RF) implements the same recursive filter; ours
// must agree closely on [0, 1] data.
TEST(DomainTransformTest, AgreesWithXimgprocRecursiveFilter) {
  const cv::Mat img = TestImage(256, 192, 1, 5);
  absl::StatusOr<cv::Mat> ours = DomainTransformFilter(img, cv::Mat(), {});
  ASSERT_TRUE(ours.ok());
  cv::Mat ref;
  cv::ximgproc::dtFilter(img, img, ref, 60, 0.33, cv::ximgproc::DTF_RF, 3);
  const double mean_diff = cv::norm(*ours, ref, cv::NORM_L1) / img.total();
  const double max_diff = cv::norm(*ours, ref, cv::NORM_INF);
  RecordProperty("mean_abs_diff", std::to_string(mean_diff));
  RecordProperty("max_abs_diff", std::to_string(max_diff));
  EXPECT_LE(mean_diff, 0.01);
}

TEST(DomainTransformTest, ColourGuideAndMultiChannelInput) {
  const cv::Mat guide = TestImage(64, 48, 3, 6);
  const cv::Mat src = TestImage(64, 48, 3, 7);
  absl::StatusOr<cv::Mat> out = DomainTransformFilter(src, guide, {});
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(out->type(), CV_32FC3);
}

TEST(DomainTransformTest, RejectsBadInput) {
  const cv::Mat img = TestImage(32, 32, 1, 1);
  EXPECT_THAT(DomainTransformFilter(cv::Mat(), cv::Mat(), {}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("domain transform input is empty")));
  EXPECT_THAT(
      DomainTransformFilter(img, TestImage(31, 32, 1, 1), {}),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("domain transform input and guide differ in size")));
  EXPECT_THAT(
      DomainTransformFilter(img, cv::Mat(), {0, 0.3, 3}),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr(
                   "domain transform: sigma_s is 0; it must be > 0 (pixels)")));
  EXPECT_THAT(
      DomainTransformFilter(img, cv::Mat(), {60, 0, 3}),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr(
              "domain transform: sigma_r is 0; it must be > 0 (guide units)")));
  EXPECT_THAT(
      DomainTransformFilter(img, cv::Mat(), {60, 0.3, 0}),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr("domain transform: iterations is 0; it must be >= 1")));
  cv::Mat inf = img.clone();
  inf.at<float>(1, 1) = std::numeric_limits<float>::infinity();
  EXPECT_THAT(
      DomainTransformFilter(inf, cv::Mat(), {}),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("domain transform input contains NaN or Inf")));
}

}  // namespace
}  // namespace hdrstereo::filters
