// SPDX-License-Identifier: GPL-3.0-or-later
//
// Cost-volume stereo on a real pair: Middlebury 2003 Cones (450x375) with
// its structured-light ground truth, scored as the folder's README defines
// (tests/support/middlebury2003.h), against the published CostFilter
// figures (Middlebury v2 table: 2.7 % bad-1px non-occluded, 8.2 % all) and
// OpenCV's StereoSGBM run here. It is the only real stereo pair in
// ../shared/data: nothing here is tuned on it (see docs/results.md, "Real
// data"). Skips, saying why, when the folder is absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "processing/eval/disparity_eval.h"
#include "processing/stereo/cost_volume_stereo.h"
#include "tests/support/middlebury2003.h"
#include "tests/support/reference_guided_filter.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::stereo {
namespace {

using ::hdrstereo::testing::Middlebury2003;

constexpr int kMaxDisparity = 59;  // the README's range 0..59

// Loads Cones or skips the test.
#define LOAD_CONES_OR_SKIP(var)                                           \
  if (!std::filesystem::is_directory(::hdrstereo::testing::ConesDir())) { \
    GTEST_SKIP() << ::hdrstereo::testing::ConesDir()                      \
                 << " is absent (../shared/data not checked out)";        \
  }                                                                       \
  ASSERT_OK_AND_ASSIGN(const Middlebury2003 var,                          \
                       ::hdrstereo::testing::LoadMiddlebury2003(          \
                           ::hdrstereo::testing::ConesDir()))

struct Scores {
  double nonocc = 0;       // bad-1px, non-occluded, all columns
  double nonocc_band = 0;  // bad-1px, non-occluded, right of the left band
  double all = 0;          // bad-1px, every known pixel
  double nonocc2 = 0, all2 = 0;  // bad-2px
};

// Missing estimates (NaN) count as bad, as for Middlebury's holes.
Scores Score(const cv::Mat& disp, const Middlebury2003& m) {
  eval::EvalOptions o;  // thresholds 0.5, 1, 2, 4; truth 0 = unknown
  absl::StatusOr<eval::DisparityEvaluation> e =
      eval::EvaluateDisparity(disp, m.truth, m.nonoccluded, cv::Mat(), o);
  // The first max-disparity columns have no partner in the right view.
  cv::Mat band(disp.size(), CV_8UC1, cv::Scalar(255));
  band.colRange(0, kMaxDisparity).setTo(0);
  absl::StatusOr<eval::DisparityEvaluation> b =
      eval::EvaluateDisparity(disp, m.truth, m.nonoccluded, band, o);
  EXPECT_TRUE(e.ok() && b.ok());
  return {e->nonoccluded.bad_percent[1], b->nonoccluded.bad_percent[1],
          e->all.bad_percent[1], e->nonoccluded.bad_percent[2],
          e->all.bad_percent[2]};
}

void Record(const std::string& tag, const Scores& s) {
  ::testing::Test::RecordProperty(tag + "_bad1_nonocc",
                                  std::to_string(s.nonocc));
  ::testing::Test::RecordProperty(tag + "_bad1_nonocc_right_of_band",
                                  std::to_string(s.nonocc_band));
  ::testing::Test::RecordProperty(tag + "_bad1_all", std::to_string(s.all));
  ::testing::Test::RecordProperty(tag + "_bad2_nonocc",
                                  std::to_string(s.nonocc2));
  ::testing::Test::RecordProperty(tag + "_bad2_all", std::to_string(s.all2));
}

StereoOptions ConesOptions() {
  StereoOptions o;
  o.min_disparity = 0;
  o.max_disparity = kMaxDisparity;
  return o;
}

// OpenCV SGBM (3-way), block 5, P1 = 8*3*25, P2 = 32*3*25, with the rest
// as in docs/benchmarks.md (disp12MaxDiff 1, preFilterCap 63, uniqueness
// 10, speckle window 100 / range 32) or, as the issue measured it, OpenCV's
// defaults for the rest (all 0: no uniqueness or speckle filtering). Holes
// are NaN.
cv::Mat Sgbm(const cv::Mat& left, const cv::Mat& right, bool opencv_defaults) {
  constexpr int kBlock = 5;
  const int num = (kMaxDisparity + 1 + 15) / 16 * 16;
  const int p1 = 8 * 3 * kBlock * kBlock, p2 = 32 * 3 * kBlock * kBlock;
  cv::Ptr<cv::StereoSGBM> sgbm =
      opencv_defaults
          ? cv::StereoSGBM::create(0, num, kBlock, p1, p2, 0, 0, 0, 0, 0,
                                   cv::StereoSGBM::MODE_SGBM_3WAY)
          : cv::StereoSGBM::create(0, num, kBlock, p1, p2, 1, 63, 10, 100, 32,
                                   cv::StereoSGBM::MODE_SGBM_3WAY);
  cv::Mat raw, disp;
  sgbm->compute(left, right, raw);
  raw.convertTo(disp, CV_32F, 1.0 / 16);
  disp.setTo(std::numeric_limits<float>::quiet_NaN(), raw < 0);
  return disp;
}

// Targets: within 1.5x (non-occluded) and 1.25x (all) of the published
// 2.7 % / 8.2 %, and better than SGBM_3WAY on the same pixels.
TEST(MiddleburyConesTest, MeetsThePublishedAccuracyAndBeatsSgbm) {
  LOAD_CONES_OR_SKIP(m);
  ASSERT_OK_AND_ASSIGN(const StereoResult ours,
                       ComputeDisparity(m.left, m.right, ConesOptions()));
  const Scores s = Score(ours.disparity, m);
  Record("ours", s);
  EXPECT_LE(s.nonocc, 4.0);
  EXPECT_LE(s.all, 10.0);

  for (const bool defaults : {false, true}) {
    const std::string tag = defaults ? "sgbm_opencv_defaults" : "sgbm";
    const cv::Mat sgbm = Sgbm(m.left, m.right, defaults);
    const Scores g = Score(sgbm, m);
    cv::Mat filled = sgbm.clone();
    FillScanlines(filled, sgbm == sgbm, 0.0f);
    const Scores gf = Score(filled, m);
    Record(tag + "_holes_bad", g);
    Record(tag + "_filled", gf);
    EXPECT_LT(s.nonocc, g.nonocc) << tag;
    EXPECT_LT(s.nonocc_band, g.nonocc_band) << tag;  // where SGBM has output
    EXPECT_LT(s.all, g.all) << tag;
    EXPECT_LT(s.nonocc, gf.nonocc) << tag;
    EXPECT_LT(s.all, gf.all) << tag;
  }
}

// The thesis' weights without gain compensation (how the matcher ran before
// step 5a: reported), and Hosni et al.'s weights (colour 0.1, gradient 0.9)
// without it, which must reach the published figures on their own.
TEST(MiddleburyConesTest, HosniWeightsReachThePublishedAccuracyToo) {
  LOAD_CONES_OR_SKIP(m);
  StereoOptions thesis = ConesOptions();
  thesis.gain_compensation = false;
  ASSERT_OK_AND_ASSIGN(const StereoResult before,
                       ComputeDisparity(m.left, m.right, thesis));
  Record("thesis_weights_no_gain", Score(before.disparity, m));

  StereoOptions hosni = thesis;
  hosni.alpha = 0.1;
  ASSERT_OK_AND_ASSIGN(const StereoResult r,
                       ComputeDisparity(m.left, m.right, hosni));
  const Scores s = Score(r.disparity, m);
  Record("hosni_weights_no_gain", s);
  EXPECT_LE(s.nonocc, 4.0);
  EXPECT_LE(s.all, 10.0);
}

// Step 5a against the truth: the gain between the views measured at the
// true correspondences (median of left / right over the non-occluded pixels
// whose values are in the same [16, 240] window; 0.993, 0.970, 0.968 for
// B, G, R) must match the gain the matcher estimated from its own first
// pass within 1 %, a third of the 3 % it corrects (measured: 0.7 % off in
// B, estimated as 1.000, and 0.45 % off in G and R).
TEST(MiddleburyConesTest, GainCompensationMeasuresTheViewsGain) {
  LOAD_CONES_OR_SKIP(m);
  ASSERT_OK_AND_ASSIGN(const StereoResult r,
                       ComputeDisparity(m.left, m.right, ConesOptions()));
  std::vector<float> ratios[3];
  for (int y = 0; y < m.left.rows; ++y) {
    for (int x = 0; x < m.left.cols; ++x) {
      if (!m.nonoccluded.at<uchar>(y, x)) continue;
      const int xr = x - static_cast<int>(std::lround(m.truth.at<float>(y, x)));
      const cv::Vec3b a = m.left.at<cv::Vec3b>(y, x);
      const cv::Vec3b b = m.right.at<cv::Vec3b>(y, xr);
      for (int c = 0; c < 3; ++c) {
        if (a[c] < 16 || a[c] > 240 || b[c] < 16 || b[c] > 240) continue;
        ratios[c].push_back(static_cast<float>(a[c]) / b[c]);
      }
    }
  }
  for (int c = 0; c < 3; ++c) {
    std::vector<float>& v = ratios[c];
    ASSERT_GT(v.size(), 10000u);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    const double truth = v[v.size() / 2];
    RecordProperty("gain_truth_" + std::to_string(c), std::to_string(truth));
    RecordProperty("gain_estimated_" + std::to_string(c),
                   std::to_string(r.right_gain[c]));
    EXPECT_NEAR(r.right_gain[c], truth, 0.01) << "channel " << c;
  }
}

// ---------------------------------------------------------------------------
// Second plain reference, in the paper's notation (Hosni et al., TPAMI 2013,
// Eq. 5; the same in Rhemann et al., CVPR 2011): C = (1 - a) min(|I - I'|,
// t1) + a min(|dx I - dx I'|, t2) with a = 0.9 on the gradient term, |I -
// I'| the mean absolute difference over the channels, dx the central
// difference of the grey image (MATLAB's gradient of rgb2gray), every
// value in [0, 1], a partner outside the image compared with 3/255 (their
// MATLAB code), the colour guided filter (r = 9, eps = 1e-4) in double
// precision per slice, and the WTA with the smaller disparity on ties. Our
// kernel is the thesis' Eq. 4.1 with the colour weight alpha; alpha = 0.1 is
// this formulation. Written from the paper, sharing no code with the kernel.

cv::Mat PaperGrey(const cv::Mat& bgr8) {
  cv::Mat g(bgr8.size(), CV_64FC1);
  for (int y = 0; y < g.rows; ++y) {
    for (int x = 0; x < g.cols; ++x) {
      const cv::Vec3b p = bgr8.at<cv::Vec3b>(y, x);
      g.at<double>(y, x) = (0.299 * p[2] + 0.587 * p[1] + 0.114 * p[0]) / 255;
    }
  }
  return g;
}

cv::Mat PaperGradient(const cv::Mat& g) {
  cv::Mat out(g.size(), CV_64FC1);
  for (int y = 0; y < g.rows; ++y) {
    for (int x = 0; x < g.cols; ++x) {
      const int a = std::max(0, x - 1);
      const int b = std::min(g.cols - 1, x + 1);
      out.at<double>(y, x) =
          (g.at<double>(y, b) - g.at<double>(y, a)) / (b - a);
    }
  }
  return out;
}

cv::Mat PaperCost(const cv::Mat& left8, const cv::Mat& right8,
                  const cv::Mat& grad_l, const cv::Mat& grad_r, int d) {
  constexpr double kA = 0.9, kT1 = 7.0 / 255, kT2 = 2.0 / 255;
  constexpr double kBorder = 3.0 / 255;
  cv::Mat c(left8.size(), CV_64FC1);
  for (int y = 0; y < c.rows; ++y) {
    for (int x = 0; x < c.cols; ++x) {
      const int xr = x - d;
      const cv::Vec3b p = left8.at<cv::Vec3b>(y, x);
      double colour = 0;
      for (int k = 0; k < 3; ++k) {
        const double q =
            xr >= 0 ? right8.at<cv::Vec3b>(y, xr)[k] / 255.0 : kBorder;
        colour += std::abs(p[k] / 255.0 - q) / 3;
      }
      const double gq = xr >= 0 ? grad_r.at<double>(y, xr) : kBorder;
      const double grad = std::abs(grad_l.at<double>(y, x) - gq);
      c.at<double>(y, x) =
          (1 - kA) * std::min(colour, kT1) + kA * std::min(grad, kT2);
    }
  }
  return c;
}

TEST(MiddleburyConesTest, FastKernelEqualsThePaperReferenceExceptTies) {
  LOAD_CONES_OR_SKIP(m);
  StereoOptions o = ConesOptions();
  o.alpha = 0.1;
  ASSERT_OK_AND_ASSIGN(const MatchingImages images,
                       PrepareMatchingImages(m.left, m.right, o));
  cv::Mat guide;
  m.left.convertTo(guide, CV_64FC3, 1.0 / 255);
  const cv::Mat grad_l = PaperGradient(PaperGrey(m.left));
  const cv::Mat grad_r = PaperGradient(PaperGrey(m.right));
  std::vector<cv::Mat> volume;
  double float_error = 0;  // max |fast filtered cost - reference|
  for (int d = 0; d <= kMaxDisparity; ++d) {
    volume.push_back(::hdrstereo::testing::DoubleColourGuided(
        guide, PaperCost(m.left, m.right, grad_l, grad_r, d), o.radius, o.eps));
    ASSERT_OK_AND_ASSIGN(const cv::Mat fast,
                         ComputeFilteredCostSlice(images, o, View::kLeft, d));
    cv::Mat fd;
    fast.convertTo(fd, CV_64F);
    float_error =
        std::max(float_error, cv::norm(fd, volume.back(), cv::NORM_INF));
  }
  cv::Mat labels(guide.size(), CV_32FC1);
  for (int y = 0; y < labels.rows; ++y) {
    for (int x = 0; x < labels.cols; ++x) {
      size_t best = 0;
      for (size_t k = 1; k < volume.size(); ++k) {
        if (volume[k].at<double>(y, x) < volume[best].at<double>(y, x)) {
          best = k;
        }
      }
      labels.at<float>(y, x) = static_cast<float>(best);
    }
  }
  ASSERT_OK_AND_ASSIGN(const WtaResult wta, ComputeWta(images, o, View::kLeft));
  // As in stereo_test's plain reference: a differing label is a tie when
  // the reference's costs of the two labels are within twice the float
  // error; every other pixel must agree.
  int differ = 0, ties = 0;
  for (int y = 0; y < labels.rows; ++y) {
    for (int x = 0; x < labels.cols; ++x) {
      const int lf = static_cast<int>(wta.labels.at<float>(y, x));
      const int lr = static_cast<int>(labels.at<float>(y, x));
      if (lf == lr) continue;
      ++differ;
      const double cf = volume[static_cast<size_t>(lf)].at<double>(y, x);
      const double cr = volume[static_cast<size_t>(lr)].at<double>(y, x);
      if (cf - cr <= 2 * float_error) ++ties;
    }
  }
  RecordProperty("float_error", std::to_string(float_error));
  RecordProperty("differing", differ);
  RecordProperty("ties", ties);
  EXPECT_LT(float_error, 1e-5);
  EXPECT_EQ(differ, ties) << differ - ties << " pixels differ without a tie";
  // The paper's formulation, WTA only (no check, fill or median), is within
  // 1.5x of the published non-occluded figure already.
  const Scores s = Score(labels, m);
  Record("paper_reference_wta", s);
  EXPECT_LE(s.nonocc, 4.0);
}

}  // namespace
}  // namespace hdrstereo::stereo
