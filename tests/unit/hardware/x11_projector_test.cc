// SPDX-License-Identifier: GPL-3.0-or-later
//
// The projector window under a private Xvfb: what is shown is read back from
// the X server with XGetImage and compared pixel for pixel.
#include "hardware/display/x11_projector.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/support/xvfb.h"

namespace hdrstereo::display {
namespace {

using ::hdrstereo::testing::Xvfb;

// Column Gray-code bit plane `bit` (0 = most significant of 10 bits).
cv::Mat GrayCodeColumns(cv::Size size, int bit) {
  cv::Mat pattern(size, CV_8UC1);
  for (int x = 0; x < size.width; ++x) {
    const int gray = x ^ (x >> 1);
    pattern.col(x).setTo((gray >> (9 - bit)) & 1 ? 255 : 0);
  }
  return pattern;
}

class X11ProjectorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    absl::StatusOr<std::unique_ptr<Xvfb>> xvfb = Xvfb::Start(800, 600);
    ASSERT_TRUE(xvfb.ok()) << xvfb.status();
    xvfb_ = *std::move(xvfb);
  }
  std::unique_ptr<Xvfb> xvfb_;
};

TEST_F(X11ProjectorTest, ShowsGrayCodeAndNoisePixelExact) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector = X11Projector::Open(
      {.display = xvfb_->display(), .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(projector.ok()) << projector.status();
  ASSERT_EQ((*projector)->resolution(), cv::Size(800, 600));

  for (int bit : {0, 4, 9}) {
    cv::Mat pattern = GrayCodeColumns({800, 600}, bit);
    ASSERT_TRUE((*projector)->Show(pattern).ok());
    cv::Mat shown = xvfb_->Screenshot({0, 0, 800, 600});
    cv::Mat expected;
    cv::cvtColor(pattern, expected, cv::COLOR_GRAY2BGR);
    EXPECT_EQ(cv::norm(shown, expected, cv::NORM_INF), 0) << "bit " << bit;
  }

  // Arbitrary colour content, to catch channel order or stride mistakes.
  cv::Mat noise(600, 800, CV_8UC3);
  cv::randu(noise, 0, 256);
  ASSERT_TRUE((*projector)->Show(noise).ok());
  EXPECT_EQ(cv::norm(xvfb_->Screenshot({0, 0, 800, 600}), noise, cv::NORM_INF),
            0);

  ASSERT_TRUE((*projector)->Blank().ok());
  EXPECT_EQ(
      cv::countNonZero(cv::Mat(xvfb_->Screenshot({0, 0, 800, 600})).reshape(1)),
      0);
}

TEST_F(X11ProjectorTest, RegionOfAScreenForASecondMonitor) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector =
      X11Projector::Open({.display = xvfb_->display(),
                          .x = 160,
                          .y = 100,
                          .width_px = 320,
                          .height_px = 240,
                          .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(projector.ok()) << projector.status();
  cv::Mat pattern(240, 320, CV_8UC1);
  cv::randu(pattern, 0, 256);
  ASSERT_TRUE((*projector)->Show(pattern).ok());
  cv::Mat expected;
  cv::cvtColor(pattern, expected, cv::COLOR_GRAY2BGR);
  EXPECT_EQ(
      cv::norm(xvfb_->Screenshot({160, 100, 320, 240}), expected, cv::NORM_INF),
      0);
}

TEST_F(X11ProjectorTest, WrongSizeOrTypeIsRefusedAndScreenUnchanged) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector = X11Projector::Open(
      {.display = xvfb_->display(), .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(projector.ok());
  cv::Mat white(600, 800, CV_8UC1, cv::Scalar(255));
  ASSERT_TRUE((*projector)->Show(white).ok());
  EXPECT_EQ((*projector)->Show(cv::Mat::zeros(480, 640, CV_8UC1)).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ((*projector)->Show(cv::Mat::zeros(600, 800, CV_32FC1)).code(),
            absl::StatusCode::kInvalidArgument);
  cv::Mat shown = xvfb_->Screenshot({0, 0, 800, 600});
  EXPECT_EQ(cv::countNonZero(shown.reshape(1) != 255), 0);
}

TEST(X11ProjectorOpenTest, MissingDisplayIsAClearError) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector =
      X11Projector::Open({.display = ":987654"});
  ASSERT_FALSE(projector.ok());
  EXPECT_EQ(projector.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(projector.status().message().find(":987654"),
            absl::string_view::npos);
}

}  // namespace
}  // namespace hdrstereo::display
