// SPDX-License-Identifier: GPL-3.0-or-later
//
// The tone-mapping path of the thesis (tone-map the pair, match it) on the
// one real stereo pair in ../shared/data, Middlebury 2003 Cones, scored
// against its structured-light truth. Cones is one 8-bit exposure per view,
// so it is linearised with the sRGB-like gamma 2.2 (not the camera's
// measured response) and carries no more than 8 bits of range: it checks
// that each operator keeps a real, textured pair matchable and consistent
// between two real views (real noise, a 3 % gain difference, real
// occlusions); it cannot show what tone mapping gains on HDR scenes or how
// the operators treat the noise of an HDR merge (docs/results.md, "Tone
// mapping for matching"). Skips, saying why, when the folder is absent.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "processing/eval/disparity_eval.h"
#include "processing/stereo/cost_volume_stereo.h"
#include "processing/tonemap/tonemap.h"
#include "tests/support/middlebury2003.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::tonemap {
namespace {

using ::hdrstereo::testing::LinearisedWithGamma22;
using ::hdrstereo::testing::Middlebury2003;

double BadNonoccluded(const cv::Mat& disp, const Middlebury2003& m) {
  absl::StatusOr<eval::DisparityEvaluation> e =
      eval::EvaluateDisparity(disp, m.truth, m.nonoccluded, cv::Mat(), {});
  EXPECT_TRUE(e.ok()) << e.status();
  return e.ok() ? e->nonoccluded.bad_percent[1] : 100.0;
}

// Mean |grey left(x) - grey right(x - d)| over the non-occluded pixels, in
// 8-bit levels, at the true disparity d (linear interpolation): how far the
// operator maps the same surface point to different values in the views.
double MeanDifferenceAtTruth(const cv::Mat& left8, const cv::Mat& right8,
                             const Middlebury2003& m) {
  cv::Mat gl, gr;
  cv::cvtColor(left8, gl, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right8, gr, cv::COLOR_BGR2GRAY);
  double sum = 0;
  long n = 0;
  for (int y = 0; y < gl.rows; ++y) {
    for (int x = 0; x < gl.cols; ++x) {
      if (!m.nonoccluded.at<uchar>(y, x)) continue;
      const float xr = x - m.truth.at<float>(y, x);
      const int x0 = static_cast<int>(std::floor(xr));
      if (x0 < 0 || x0 + 1 >= gr.cols) continue;
      const float f = xr - x0;
      const float v =
          gr.at<uchar>(y, x0) * (1 - f) + gr.at<uchar>(y, x0 + 1) * f;
      sum += std::abs(gl.at<uchar>(y, x) - v);
      ++n;
    }
  }
  return n ? sum / n : 0;
}

TEST(ConesToneMappedMatchingTest, EveryOperatorKeepsTheRealPairMatchable) {
  const std::filesystem::path dir = ::hdrstereo::testing::ConesDir();
  if (!std::filesystem::is_directory(dir)) {
    GTEST_SKIP() << dir << " is absent (../shared/data not checked out)";
  }
  ASSERT_OK_AND_ASSIGN(const Middlebury2003 m,
                       ::hdrstereo::testing::LoadMiddlebury2003(dir));
  stereo::StereoOptions o;
  o.min_disparity = 0;
  o.max_disparity = 59;
  ASSERT_OK_AND_ASSIGN(const stereo::StereoResult ldr,
                       stereo::ComputeDisparity(m.left, m.right, o));
  const double ldr_bad = BadNonoccluded(ldr.disparity, m);
  RecordProperty("ldr_bad1_nonocc", std::to_string(ldr_bad));
  RecordProperty("ldr_difference_at_truth",
                 std::to_string(MeanDifferenceAtTruth(m.left, m.right, m)));

  const cv::Mat left = LinearisedWithGamma22(m.left),
                right = LinearisedWithGamma22(m.right);
  for (const Operator op : AllOperators()) {
    const std::string name = OperatorName(op);
    ASSERT_OK_AND_ASSIGN(const auto pair, ToneMapPair(left, right, op));
    ASSERT_OK_AND_ASSIGN(const stereo::StereoResult r,
                         stereo::ComputeDisparity(pair.first, pair.second, o));
    const double bad = BadNonoccluded(r.disparity, m);
    const double diff = MeanDifferenceAtTruth(pair.first, pair.second, m);
    RecordProperty(name + "_bad1_nonocc", std::to_string(bad));
    RecordProperty(name + "_difference_at_truth", std::to_string(diff));
    // Bounds set from the measurement (2026-12-02, bad-1px non-occluded:
    // matched untouched 2.46 %, Reinhard 2.32, Drago 2.77, guided 3.43,
    // WLS 3.65, domain transform 4.10, Durand 4.94, Fattal 10.72) with a
    // margin of about a fifth; nothing was tuned to reach them.
    EXPECT_LE(bad, op == Operator::kFattal ? 13.0 : 6.0) << name;
    if (op == Operator::kWls || op == Operator::kDomainTransform) {
      // On a real textured pair the per-view base layers stay consistent
      // enough: within 2.5 points of matching the pair untouched.
      EXPECT_LE(bad, ldr_bad + 2.5) << name;
    }
  }
}

}  // namespace
}  // namespace hdrstereo::tonemap
