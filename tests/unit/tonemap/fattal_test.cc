// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/tonemap/fattal.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "tests/support/status_matchers.h"
#include "tests/unit/tonemap/synthetic_scene.h"

namespace hdrstereo::tonemap {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::SyntheticScene;

cv::Mat LogLuminance(const cv::Mat& bgr) {
  cv::Mat lum;
  cv::transform(bgr, lum, cv::Matx13f(0.0722f, 0.7152f, 0.2126f));
  cv::Mat out;
  cv::log(lum, out);
  return out;
}

// Neumann 5-point Laplacian (reflecting boundary) in double.
cv::Mat Laplacian5(const cv::Mat& u) {
  cv::Mat out(u.size(), CV_64FC1);
  for (int y = 0; y < u.rows; ++y) {
    for (int x = 0; x < u.cols; ++x) {
      const double c = u.at<double>(y, x);
      double s = 0.0;
      if (x > 0) s += u.at<double>(y, x - 1) - c;
      if (x + 1 < u.cols) s += u.at<double>(y, x + 1) - c;
      if (y > 0) s += u.at<double>(y - 1, x) - c;
      if (y + 1 < u.rows) s += u.at<double>(y + 1, x) - c;
      out.at<double>(y, x) = s;
    }
  }
  return out;
}

class PoissonSizesTest : public ::testing::TestWithParam<cv::Size> {};

TEST_P(PoissonSizesTest, SolutionSatisfiesTheDiscreteEquation) {
  const cv::Size size = GetParam();
  cv::Mat f(size, CV_64FC1);
  cv::RNG(1).fill(f, cv::RNG::UNIFORM, -1.0, 1.0);
  f -= cv::mean(f)[0];  // compatible right-hand side
  absl::StatusOr<cv::Mat> u = SolvePoissonNeumann(f);
  ASSERT_TRUE(u.ok()) << u.status();
  EXPECT_LE(cv::norm(Laplacian5(*u), f, cv::NORM_INF), 1e-9);
  EXPECT_NEAR(cv::mean(*u)[0], 0.0, 1e-12);
}

// Even, odd and mixed sizes (odd ones are padded for cv::dct).
INSTANTIATE_TEST_SUITE_P(EvenOdd, PoissonSizesTest,
                         ::testing::Values(cv::Size(64, 48), cv::Size(63, 47),
                                           cv::Size(64, 47), cv::Size(5, 8)));

// beta = 1: nothing attenuated, the Poisson reconstruction must give the
// log-luminance back. Tolerance 1e-4 in ln units (0.01 % luminance) on a
// scene spanning ln(8000) ~ 9.
TEST(FattalTest, ReproducesInputWithoutAttenuation) {
  for (const cv::Size size : {cv::Size(256, 192), cv::Size(255, 191)}) {
    const cv::Mat h = LogLuminance(SyntheticScene(size.width, size.height));
    FattalOptions p;
    p.beta = 1.0;
    absl::StatusOr<std::vector<cv::Mat>> out = FattalCompress({h}, p);
    ASSERT_TRUE(out.ok()) << out.status();
    const double err = cv::norm((*out)[0], h, cv::NORM_INF);
    RecordProperty("max_abs_err_" + std::to_string(size.width),
                   std::to_string(err));
    EXPECT_LE(err, 1e-4) << size;
  }
}

TEST(FattalTest, CompressesTheDynamicRange) {
  const cv::Mat h = LogLuminance(SyntheticScene(256, 192));
  absl::StatusOr<std::vector<cv::Mat>> out = FattalCompress({h}, {});
  ASSERT_TRUE(out.ok());
  double in_lo, in_hi, out_lo, out_hi;
  cv::minMaxLoc(h, &in_lo, &in_hi);
  cv::minMaxLoc((*out)[0], &out_lo, &out_hi);
  // beta = 0.85 on every level: the ln range shrinks by at least a third.
  EXPECT_LT(out_hi - out_lo, (in_hi - in_lo) * 2.0 / 3.0);
}

// Wider than solve_width: compressed at that width and the change brought
// back, so the output keeps the input's size and, with nothing attenuated,
// is the input; with the default attenuation the large-scale range
// shrinks as at the solve width, while the finest detail (a one-pixel
// checker added to the scene) keeps its contrast.
TEST(FattalTest, ViewsWiderThanTheSolveWidthKeepTheirSizeAndDetail) {
  cv::Mat h = LogLuminance(SyntheticScene(960, 720));
  cv::Mat checker(h.size(), CV_32FC1);
  for (int y = 0; y < h.rows; ++y) {
    for (int x = 0; x < h.cols; ++x) {
      checker.at<float>(y, x) = ((x + y) % 2 == 0) ? 0.05f : -0.05f;
    }
  }
  h += checker;
  FattalOptions flat;
  flat.beta = 1.0;
  ASSERT_OK_AND_ASSIGN(const std::vector<cv::Mat> same,
                       FattalCompress({h}, flat));
  ASSERT_EQ(same[0].size(), h.size());
  EXPECT_LE(cv::norm(same[0], h, cv::NORM_INF), 1e-3);

  ASSERT_OK_AND_ASSIGN(const std::vector<cv::Mat> out, FattalCompress({h}, {}));
  ASSERT_EQ(out[0].size(), h.size());
  cv::Mat smooth_in, smooth_out;
  cv::blur(h, smooth_in, cv::Size(9, 9));
  cv::blur(out[0], smooth_out, cv::Size(9, 9));
  double in_lo, in_hi, out_lo, out_hi;
  cv::minMaxLoc(smooth_in, &in_lo, &in_hi);
  cv::minMaxLoc(smooth_out, &out_lo, &out_hi);
  EXPECT_LT(out_hi - out_lo, (in_hi - in_lo) * 2.0 / 3.0);
  // The checker: neighbours still differ by about 0.1 (ln units).
  double detail = 0;
  for (int x = 1; x < out[0].cols; ++x) {
    detail += std::abs(out[0].at<float>(360, x) - out[0].at<float>(360, x - 1));
  }
  EXPECT_GT(detail / (out[0].cols - 1), 0.09);
}

TEST(FattalTest, RejectsBadParameters) {
  const cv::Mat h(16, 16, CV_32FC1, cv::Scalar(1));
  FattalOptions p;
  p.beta = 1.5;
  EXPECT_THAT(FattalCompress({h}, p),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("Fattal: beta is 1.5; it must be in (0, 1]")));
  EXPECT_THAT(
      FattalCompress({}, {}),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("no views")));
  EXPECT_THAT(SolvePoissonNeumann(cv::Mat()),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("Poisson right-hand side must be a non-empty "
                                 "CV_32FC1/CV_64FC1")));
}

}  // namespace
}  // namespace hdrstereo::tonemap
