// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/wls_filter.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>

#include "tests/support/status_matchers.h"
#include "tests/unit/filters/test_images.h"

namespace hdrstereo::filters {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::StepImage;
using ::hdrstereo::testing::TestImage;

// Farbman's system assembled densely from the paper's definition and solved
// by Cholesky in double precision.
cv::Mat DenseWls(const cv::Mat& g, const cv::Mat& l, double alpha,
                 double lambda, double small) {
  const int w = g.cols, h = g.rows, n = w * h;
  cv::Mat a = cv::Mat::eye(n, n, CV_64F);
  auto couple = [&](int i, int j, double dl) {
    const double wgt = lambda / (std::pow(std::fabs(dl), alpha) + small);
    a.at<double>(i, i) += wgt;
    a.at<double>(j, j) += wgt;
    a.at<double>(i, j) -= wgt;
    a.at<double>(j, i) -= wgt;
  };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int i = y * w + x;
      if (x + 1 < w)
        couple(i, i + 1, l.at<float>(y, x + 1) - l.at<float>(y, x));
      if (y + 1 < h)
        couple(i, i + w, l.at<float>(y + 1, x) - l.at<float>(y, x));
    }
  }
  cv::Mat b;
  g.reshape(1, n).convertTo(b, CV_64F);
  cv::Mat u;
  cv::solve(a, b, u, cv::DECOMP_CHOLESKY);
  cv::Mat out;
  u.reshape(1, h).convertTo(out, CV_32F);
  return out;
}

TEST(WlsFilterTest, MatchesDenseSolveOfFarbmansSystem) {
  const cv::Mat g = TestImage(17, 13, 1, 1);  // odd sizes on purpose
  const cv::Mat ref = DenseWls(g, g, 1.2, 1.0, 1e-4);
  for (WlsOptions::Preconditioner pc :
       {WlsOptions::Preconditioner::kMultigrid,
        WlsOptions::Preconditioner::kIncompleteCholesky}) {
    WlsOptions o;
    o.tolerance = 1e-7;
    o.preconditioner = pc;
    WlsReport report;
    absl::StatusOr<cv::Mat> ours = WlsFilter(g, cv::Mat(), o, &report);
    ASSERT_TRUE(ours.ok()) << ours.status();
    EXPECT_LE(report.relative_residual, 1e-7);
    EXPECT_LE(cv::norm(*ours, ref, cv::NORM_INF), 1e-4);
  }
}

TEST(WlsFilterTest, SeparateGuideMatchesDenseSolve) {
  const cv::Mat g = TestImage(12, 10, 1, 2);
  const cv::Mat l = TestImage(12, 10, 1, 3);
  WlsOptions o;
  o.tolerance = 1e-7;
  o.alpha = 1.8;
  o.lambda = 0.35;
  absl::StatusOr<cv::Mat> ours = WlsFilter(g, l, o);
  ASSERT_TRUE(ours.ok());
  EXPECT_LE(cv::norm(*ours, DenseWls(g, l, 1.8, 0.35, 1e-4), cv::NORM_INF),
            1e-4);
}

TEST(WlsFilterTest, ConvergesOnALargerImage) {
  const cv::Mat g = TestImage(256, 192, 1, 4);
  WlsReport report;
  absl::StatusOr<cv::Mat> out = WlsFilter(g, cv::Mat(), {}, &report);
  ASSERT_TRUE(out.ok());
  RecordProperty("iterations", report.iterations);
  EXPECT_LE(report.relative_residual, 1e-4);
  EXPECT_LT(report.iterations, 2000);
}

TEST(WlsFilterTest, KeepsAStepEdgeAndSmoothsNoise) {
  cv::Mat img = StepImage(96, 48, 48, 0.2f, 0.8f);
  cv::Mat noise(img.size(), CV_32FC1);
  cv::RNG(5).fill(noise, cv::RNG::NORMAL, 0.0, 0.002);
  img += noise;
  absl::StatusOr<cv::Mat> out = WlsFilter(img, cv::Mat(), {});
  ASSERT_TRUE(out.ok());
  // lambda = 1 couples across the edge with weight ~1.8 against a data term
  // of 1 per pixel, so each half bends towards the other near the edge
  // (over the diffusion length, ~30 px here): the step keeps >= 90 % of its
  // height. The noise is removed: what is left after subtracting the column
  // means (the leak profile) has < 1/4 of the input's standard deviation.
  cv::Mat column_means;
  cv::reduce(*out, column_means, 0, cv::REDUCE_AVG);
  EXPECT_GE(column_means.at<float>(0, 60) - column_means.at<float>(0, 36),
            0.9 * 0.6);
  const cv::Mat residual = *out - cv::repeat(column_means, out->rows, 1);
  cv::Scalar mean, sd;
  cv::meanStdDev(residual, mean, sd);
  EXPECT_LT(sd[0], 0.002 / 4);
  // Sharp: the jump happens between columns 47 and 48.
  EXPECT_GE(out->at<float>(24, 48) - out->at<float>(24, 47), 0.8 * 0.6);
}

// Tall enough (>= 128 rows) for the block-parallel multigrid smoother: both
// preconditioners must reach the same solution.
TEST(WlsFilterTest, PreconditionersAgreeOnATallImage) {
  const cv::Mat g = TestImage(48, 150, 1, 8);
  WlsOptions o;
  o.tolerance = 1e-7;
  absl::StatusOr<cv::Mat> mg = WlsFilter(g, cv::Mat(), o);
  o.preconditioner = WlsOptions::Preconditioner::kIncompleteCholesky;
  absl::StatusOr<cv::Mat> ic = WlsFilter(g, cv::Mat(), o);
  ASSERT_TRUE(mg.ok() && ic.ok());
  EXPECT_LE(cv::norm(*mg, *ic, cv::NORM_INF), 1e-4);
}

// The parallel parts (block Gauss-Seidel, chunked dot products) are
// deterministic: the result does not depend on the number of threads.
TEST(WlsFilterTest, IndependentOfThreadCount) {
  const cv::Mat g = TestImage(200, 160, 1, 7);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  absl::StatusOr<cv::Mat> one = WlsFilter(g, cv::Mat(), {});
  cv::setNumThreads(4);
  absl::StatusOr<cv::Mat> four = WlsFilter(g, cv::Mat(), {});
  cv::setNumThreads(threads);
  ASSERT_TRUE(one.ok() && four.ok());
  EXPECT_EQ(cv::norm(*one, *four, cv::NORM_INF), 0.0);
}

TEST(WlsFilterTest, ZeroLambdaIsIdentity) {
  const cv::Mat g = TestImage(40, 30, 1, 6);
  WlsOptions o;
  o.lambda = 0.0;
  absl::StatusOr<cv::Mat> out = WlsFilter(g, cv::Mat(), o);
  ASSERT_TRUE(out.ok());
  EXPECT_LE(cv::norm(*out, g, cv::NORM_INF), 1e-6);
}

TEST(WlsFilterTest, RejectsBadInput) {
  const cv::Mat g = TestImage(16, 16, 1, 1);
  EXPECT_THAT(WlsFilter(cv::Mat(), cv::Mat(), {}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("WLS input is empty")));
  EXPECT_THAT(
      WlsFilter(TestImage(16, 16, 3, 1), cv::Mat(), {}),
      StatusIs(
          absl::StatusCode::kInvalidArgument,
          HasSubstr("WLS guide has an unsupported number of channels (3)")));
  EXPECT_THAT(WlsFilter(g, TestImage(15, 16, 1, 1), {}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("WLS input and guide differ in size")));
  WlsOptions bad;
  bad.alpha = 0;
  EXPECT_THAT(WlsFilter(g, cv::Mat(), bad),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("WLS: alpha is 0; it must be > 0")));
  cv::Mat nan = g.clone();
  nan.at<float>(2, 2) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THAT(WlsFilter(nan, cv::Mat(), {}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("WLS input contains NaN or Inf")));
}

}  // namespace
}  // namespace hdrstereo::filters
