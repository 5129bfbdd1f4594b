// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/domain_transform.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

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

// The expectations: outputs of the project's own recursive filter (removed
// in favour of OpenCV's DTF_RF, which it matched to 1.8e-7), recorded on
// TestImage(256, 192, 1, 5) self-guided with the default options (60, 0.33,
// 3 iterations) at every 38th row and 51st column, and on a colour guide
// with 3-channel input. They were not computed with OpenCV.
struct Sample {
  int y, x;
  float value;
};
constexpr Sample kRecordedGrey[] = {
    {0, 0, 3.29017878e-01f},     {0, 51, 3.92228186e-01f},
    {0, 102, 1.41929567e-01f},   {0, 153, 7.65953720e-01f},
    {0, 204, 4.78217125e-01f},   {0, 255, 5.91601551e-01f},
    {38, 0, 2.80167818e-01f},    {38, 51, 2.22034633e-01f},
    {38, 102, 4.29225653e-01f},  {38, 153, 4.65549350e-01f},
    {38, 204, 6.96540236e-01f},  {38, 255, 6.01499856e-01f},
    {76, 0, 3.12677890e-01f},    {76, 51, 3.48435462e-01f},
    {76, 102, 2.21692979e-01f},  {76, 153, 6.93434536e-01f},
    {76, 204, 5.36121249e-01f},  {76, 255, 5.97338259e-01f},
    {114, 0, 2.90742785e-01f},   {114, 51, 2.90805429e-01f},
    {114, 102, 3.13913822e-01f}, {114, 153, 5.90330064e-01f},
    {114, 204, 6.00997865e-01f}, {114, 255, 6.03601635e-01f},
    {152, 0, 9.43202004e-02f},   {152, 51, 8.33778307e-02f},
    {152, 102, 3.59257340e-01f}, {152, 153, 5.44086754e-01f},
    {152, 204, 6.38914764e-01f}, {152, 255, 6.04009390e-01f},
    {190, 0, 1.25556439e-01f},   {190, 51, 1.91751242e-01f},
    {190, 102, 1.50442764e-01f}, {190, 153, 7.58192241e-01f},
    {190, 204, 4.89949435e-01f}, {190, 255, 5.94489396e-01f},
};
// Sum of all 256 x 192 outputs of the same run.
constexpr double kRecordedGreySum = 21127.80317;

struct ColourSample {
  int y, x;
  cv::Vec3f value;
};
const ColourSample kRecordedColour[] = {
    {0, 0, {3.13510001e-01f, 4.81018782e-01f, 4.82444644e-01f}},
    {0, 31, {4.96619433e-01f, 4.10835057e-01f, 2.22194225e-01f}},
    {0, 62, {6.14701152e-01f, 4.36628282e-01f, 4.13569033e-01f}},
    {23, 0, {2.97753721e-01f, 2.88386077e-01f, 2.94362813e-01f}},
    {23, 31, {2.91328937e-01f, 2.99194247e-01f, 3.10053498e-01f}},
    {23, 62, {5.99443078e-01f, 6.02187514e-01f, 6.02684379e-01f}},
    {46, 0, {8.28646570e-02f, 1.90375396e-03f, 5.57830511e-03f}},
    {46, 31, {1.04513966e-01f, 1.82252645e-01f, 3.69649112e-01f}},
    {46, 62, {5.78901470e-01f, 7.51353323e-01f, 7.84341335e-01f}},
};

TEST(DomainTransformTest, MatchesRecordedOutputsOfTheEarlierFilter) {
  const cv::Mat img = TestImage(256, 192, 1, 5);
  absl::StatusOr<cv::Mat> out = DomainTransformFilter(img, cv::Mat(), {});
  ASSERT_TRUE(out.ok()) << out.status();
  ASSERT_EQ(out->type(), CV_32FC1);
  for (const Sample& s : kRecordedGrey) {
    EXPECT_NEAR(out->at<float>(s.y, s.x), s.value, 1e-5)
        << "at (" << s.y << ", " << s.x << ")";
  }
  EXPECT_NEAR(cv::sum(*out)[0] / img.total(), kRecordedGreySum / img.total(),
              1e-5);
}

TEST(DomainTransformTest, ColourGuideAndMultiChannelInput) {
  const cv::Mat guide = TestImage(64, 48, 3, 6);
  const cv::Mat src = TestImage(64, 48, 3, 7);
  absl::StatusOr<cv::Mat> out = DomainTransformFilter(src, guide, {});
  ASSERT_TRUE(out.ok()) << out.status();
  ASSERT_EQ(out->type(), CV_32FC3);
  for (const ColourSample& s : kRecordedColour) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(out->at<cv::Vec3f>(s.y, s.x)[c], s.value[c], 1e-5)
          << "at (" << s.y << ", " << s.x << ") channel " << c;
    }
  }
}

// Channels are filtered independently: six channels (more than OpenCV
// filters at once) give each 3-channel half's own result.
TEST(DomainTransformTest, MoreThanFourChannelsAreFilteredPlaneByPlane) {
  const cv::Mat guide = TestImage(64, 48, 3, 6);
  const cv::Mat a = TestImage(64, 48, 3, 7);
  const cv::Mat b = TestImage(64, 48, 3, 8);
  cv::Mat six;
  cv::merge(std::vector<cv::Mat>{a, b}, six);
  absl::StatusOr<cv::Mat> out = DomainTransformFilter(six, guide, {});
  ASSERT_TRUE(out.ok()) << out.status();
  ASSERT_EQ(out->type(), CV_32FC(6));
  absl::StatusOr<cv::Mat> fa = DomainTransformFilter(a, guide, {});
  absl::StatusOr<cv::Mat> fb = DomainTransformFilter(b, guide, {});
  ASSERT_TRUE(fa.ok() && fb.ok());
  std::vector<cv::Mat> planes, expected, pa, pb;
  cv::split(*out, planes);
  cv::split(*fa, pa);
  cv::split(*fb, pb);
  expected.insert(expected.end(), pa.begin(), pa.end());
  expected.insert(expected.end(), pb.begin(), pb.end());
  for (int c = 0; c < 6; ++c) {
    EXPECT_LE(cv::norm(planes[c], expected[c], cv::NORM_INF), 1e-6)
        << "channel " << c;
  }
}

// 8-bit input is filtered in guide units of 0..255 and returned as float.
TEST(DomainTransformTest, EightBitInputGivesFloat) {
  cv::Mat u8;
  TestImage(64, 48, 1, 9).convertTo(u8, CV_8U, 255);
  cv::Mat f;
  u8.convertTo(f, CV_32F);
  const DomainTransformOptions o{.sigma_s = 20, .sigma_r = 40};
  absl::StatusOr<cv::Mat> from_u8 = DomainTransformFilter(u8, cv::Mat(), o);
  absl::StatusOr<cv::Mat> from_f = DomainTransformFilter(f, cv::Mat(), o);
  ASSERT_TRUE(from_u8.ok() && from_f.ok());
  EXPECT_EQ(from_u8->type(), CV_32FC1);
  EXPECT_LE(cv::norm(*from_u8, *from_f, cv::NORM_INF), 1e-4);
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
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr(
              "domain transform: sigma_s is 0; it must be >= 1 (pixels)")));
  // Below OpenCV's minimums (which it would silently raise to).
  EXPECT_THAT(
      DomainTransformFilter(img, cv::Mat(), {0.5, 0.3, 3}),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("domain transform: sigma_s is 0.5; it must be >= 1 "
                         "(pixels)")));
  EXPECT_THAT(
      DomainTransformFilter(img, cv::Mat(), {60, 0.005, 3}),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("domain transform: sigma_r is 0.005; it must be >= "
                         "0.01 (guide units)")));
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
