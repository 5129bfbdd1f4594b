// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/reliability.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::fusion {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

constexpr int kWidth = 320;
constexpr int kHeight = 120;

// Truth: 20 px on the left half, 30 px on the right half.
cv::Mat Truth() {
  cv::Mat t(kHeight, kWidth, CV_32FC1, cv::Scalar(20));
  t.colRange(kWidth / 2, kWidth).setTo(30);
  return t;
}

double Rmse(const cv::Mat& d, const cv::Mat& truth) {
  const cv::Mat e = d - truth;
  return std::sqrt(cv::mean(e.mul(e))[0]);
}

struct Candidates {
  std::vector<cv::Mat> disparity, consistent;
};

// Three right candidates (5 % of pixels off by 6..12 px, 90 % pass their
// left-right check) and four that fail together on the right half (all
// 8 px too far there, a quarter of those pixels passing their check) --
// the way the failing tone-mapped pairs behave at large sizes: a majority
// agreeing on a wrong value, mostly caught by their own left-right check.
Candidates Mixed(std::mt19937& rng) {
  const cv::Mat truth = Truth();
  std::uniform_real_distribution<float> u(0, 1);
  Candidates c;
  for (int k = 0; k < 7; ++k) {
    const bool good = k < 3;
    cv::Mat d = truth.clone();
    cv::Mat lr(truth.size(), CV_8UC1);
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const bool wrong = good ? u(rng) < 0.05f : x >= kWidth / 2;
        if (wrong) d.at<float>(y, x) += good ? 6.0f + 6.0f * u(rng) : 8.0f;
        const float pass = good || !wrong ? 0.9f : 0.25f;
        lr.at<uchar>(y, x) = u(rng) < pass ? 255 : 0;
      }
    }
    c.disparity.push_back(d);
    c.consistent.push_back(lr);
  }
  return c;
}

FusionOptions Params() {
  FusionOptions p;
  p.max_disp = 48;
  return p;
}

cv::Mat FlatGuide() {
  return cv::Mat(kHeight, kWidth, CV_8UC1, cv::Scalar(128));
}

TEST(ReliabilityTest, FollowsTheCandidatesTheEvidenceSupportsNotTheMajority) {
  std::mt19937 rng(7);
  const Candidates c = Mixed(rng);
  const cv::Mat truth = Truth();
  ASSERT_OK_AND_ASSIGN(const cv::Mat median, FuseMedian(c.disparity, 48));
  ASSERT_OK_AND_ASSIGN(const FusionResult thesis,
                       FuseAlphaExpansion(c.disparity, FlatGuide(), Params()));
  ASSERT_OK_AND_ASSIGN(
      const FusionResult robust,
      FuseByReliability(c.disparity, c.consistent, FlatGuide(), FlatGuide(),
                        FlatGuide(), Params(), {}));
  // The majority is 8 px off on half the image: RMSE sqrt(32) = 5.7.
  EXPECT_GT(Rmse(median, truth), 5.0);
  EXPECT_GT(Rmse(thesis.disparity, truth), 5.0);
  // Weighed by evidence, fusion recovers the truth (measured: 0).
  EXPECT_LT(Rmse(robust.disparity, truth), 0.5);
  const cv::Mat off = cv::abs(robust.disparity - truth) > 1;
  EXPECT_LT(cv::countNonZero(off), kWidth * kHeight / 100);
}

TEST(ReliabilityTest, EndsWithPlanesOnSurfacesWithoutTexture) {
  // A slanted surface seen by seven candidates (integer labels, as
  // matched), all of them with the wall's 10 px on its top quarter: the
  // way every candidate fails alike where there is no texture. The view
  // is one grey, so the surface is one untextured segment.
  cv::Mat truth(kHeight, kWidth, CV_32FC1);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      truth.at<float>(y, x) = 20.0f + 0.05f * x + 0.02f * y;
    }
  }
  cv::Mat candidate;
  truth.convertTo(candidate, CV_32S);  // rounded
  candidate.convertTo(candidate, CV_32F);
  candidate.rowRange(0, kHeight / 4).setTo(10);
  const std::vector<cv::Mat> seven(7, candidate);
  ASSERT_OK_AND_ASSIGN(const FusionResult planes,
                       FuseByReliability(seven, {}, FlatGuide(), FlatGuide(),
                                         FlatGuide(), Params(), {}));
  EXPECT_LT(Rmse(planes.disparity, truth), 0.1);
  // One segment took its plane: at least the wall's quarter changed; the
  // view has no texture, so the photo-consistency choice changed nothing.
  EXPECT_EQ(planes.refinement.segments, 1);
  EXPECT_EQ(planes.refinement.planes, 1);
  EXPECT_GT(planes.refinement.plane_fraction, 0.25);
  EXPECT_EQ(planes.refinement.photo_fraction, 0);
  ReliabilityOptions off;
  off.planes.enabled = false;
  off.photo.enabled = false;  // then no view is needed
  ASSERT_OK_AND_ASSIGN(const FusionResult labels,
                       FuseByReliability(seven, {}, FlatGuide(), cv::Mat(),
                                         cv::Mat(), Params(), off));
  EXPECT_EQ(cv::countNonZero(labels.disparity != candidate), 0);
}

TEST(ReliabilityTest, EndsByRemovingIslandsAndCountsThem) {
  // Seven candidates that agree on an island of 9 px at 40 on a 20 px wall,
  // where the guide has an edge too: the graph cuts keep it, the speckle
  // filter does not.
  const cv::Rect island(100, 50, 3, 3);
  cv::Mat candidate(kHeight, kWidth, CV_32FC1, cv::Scalar(20));
  candidate(island).setTo(40);
  const std::vector<cv::Mat> seven(7, candidate);
  cv::Mat guide = FlatGuide();
  guide(island).setTo(255);
  ReliabilityOptions o;
  o.planes.enabled = false;
  o.photo.enabled = false;
  ASSERT_OK_AND_ASSIGN(
      const FusionResult r,
      FuseByReliability(seven, {}, guide, cv::Mat(), cv::Mat(), Params(), o));
  EXPECT_EQ(cv::countNonZero(r.disparity != 20), 0);
  EXPECT_DOUBLE_EQ(r.refinement.speckle_fraction, 9.0 / (kWidth * kHeight));
  EXPECT_EQ(r.refinement.segments, 0);
  o.speckles.enabled = false;
  ASSERT_OK_AND_ASSIGN(
      const FusionResult kept,
      FuseByReliability(seven, {}, guide, cv::Mat(), cv::Mat(), Params(), o));
  EXPECT_EQ(cv::countNonZero(kept.disparity != candidate), 0);
  EXPECT_EQ(kept.refinement.speckle_fraction, 0);
}

TEST(ReliabilityTest,
     ConfidencesFavourTheCandidatesThatAgreeAndPassTheirCheck) {
  std::mt19937 rng(11);
  const Candidates c = Mixed(rng);
  ASSERT_OK_AND_ASSIGN(
      const std::vector<cv::Mat> conf,
      CandidateConfidences(c.disparity, c.consistent, Truth(), {}));
  ASSERT_EQ(conf.size(), 7u);
  const cv::Point right_half(kWidth * 3 / 4, kHeight / 2);
  for (int k = 0; k < 7; ++k) {
    const float v = conf[static_cast<size_t>(k)].at<float>(right_half);
    EXPECT_GE(v, 0.0f);
    EXPECT_LE(v, 1.0f);
    if (k < 3) {
      EXPECT_GT(v, 0.8f) << "candidate " << k;
    } else {
      EXPECT_LT(v, 0.4f) << "candidate " << k;
    }
  }
}

TEST(ReliabilityTest, SizesAreRelativeToTheImage) {
  // A candidate 3 px off agrees at 1200 px width (tau 3.75 px) and not at
  // 320 px (tau 1 px).
  for (const auto& [width, agrees] : {std::pair{320, false}, {1200, true}}) {
    const cv::Mat estimate(8, width, CV_32FC1, cv::Scalar(40));
    const std::vector<cv::Mat> candidates = {
        estimate.clone(), cv::Mat(8, width, CV_32FC1, cv::Scalar(43))};
    ASSERT_OK_AND_ASSIGN(const std::vector<cv::Mat> conf,
                         CandidateConfidences(candidates, {}, estimate, {}));
    EXPECT_FLOAT_EQ(conf[0].at<float>(4, width / 2), 1.0f);
    EXPECT_FLOAT_EQ(conf[1].at<float>(4, width / 2), agrees ? 1.0f : 0.0f)
        << width;
  }
}

TEST(ReliabilityTest, NoSupportAnywhereKeepsEveryCandidate) {
  const cv::Mat estimate(8, 32, CV_32FC1, cv::Scalar(10));
  const std::vector<cv::Mat> candidates = {
      cv::Mat(8, 32, CV_32FC1, cv::Scalar(1)),
      cv::Mat(8, 32, CV_32FC1, cv::Scalar(20))};
  ASSERT_OK_AND_ASSIGN(const std::vector<cv::Mat> conf,
                       CandidateConfidences(candidates, {}, estimate, {}));
  for (const cv::Mat& c : conf) {
    EXPECT_EQ(cv::countNonZero(c != 1.0f), 0);
  }
}

TEST(ReliabilityTest, TheFirstEstimateIsTheMedianOfTheConsistentCandidates) {
  // 80 px wide, so OpenCV's vectorised comparisons are used.
  const cv::Size size(80, 4);
  const std::vector<cv::Mat> candidates = {
      cv::Mat(size, CV_32FC1, cv::Scalar(10)),
      cv::Mat(size, CV_32FC1, cv::Scalar(20)),
      cv::Mat(size, CV_32FC1, cv::Scalar(40))};
  // Candidate 2 passes its check on the left half only; columns >= 60
  // pass nowhere (the median of all three there).
  std::vector<cv::Mat> lr(3);
  for (int k = 0; k < 3; ++k) {
    lr[static_cast<size_t>(k)] = cv::Mat(size, CV_8UC1, cv::Scalar(255));
    lr[static_cast<size_t>(k)].colRange(60, 80).setTo(0);
  }
  lr[2].colRange(40, 60).setTo(0);
  ASSERT_OK_AND_ASSIGN(const cv::Mat m, ConsistentMedian(candidates, lr, 64));
  EXPECT_FLOAT_EQ(m.at<float>(1, 10), 20.0f);  // all three pass
  EXPECT_FLOAT_EQ(m.at<float>(1, 50), 15.0f);  // 10 and 20 pass
  EXPECT_FLOAT_EQ(m.at<float>(1, 70), 20.0f);  // none passes: all three
  ASSERT_OK_AND_ASSIGN(const cv::Mat plain,
                       ConsistentMedian(candidates, {}, 64));
  EXPECT_EQ(cv::countNonZero(plain != 20.0f), 0);
}

TEST(ReliabilityTest, ReliablePixelsHaveTwoConsistentCandidatesThatAgree) {
  // 80 px wide, so OpenCV's vectorised comparisons are used.
  const cv::Size size(80, 4);
  const cv::Mat fused(size, CV_32FC1, cv::Scalar(20));
  // Columns 0..19: two candidates at 20.5 pass; 20..39: one of them fails
  // its check; 40..59: one is 2 px off; 60..79: the third candidate, at
  // 20, makes two again.
  std::vector<cv::Mat> candidates = {cv::Mat(size, CV_32FC1, cv::Scalar(20.5)),
                                     cv::Mat(size, CV_32FC1, cv::Scalar(20.5)),
                                     cv::Mat(size, CV_32FC1, cv::Scalar(35))};
  std::vector<cv::Mat> lr(3, cv::Mat());
  lr[1] = cv::Mat(size, CV_8UC1, cv::Scalar(255));
  lr[1].colRange(20, 40).setTo(0);
  candidates[1].colRange(40, 80).setTo(22);
  candidates[2].colRange(60, 80).setTo(20);
  ASSERT_OK_AND_ASSIGN(const cv::Mat r,
                       ReliablePixels(candidates, lr, fused, 1.0));
  EXPECT_EQ(r.at<uchar>(1, 10), 255);
  EXPECT_EQ(r.at<uchar>(1, 30), 0);
  EXPECT_EQ(r.at<uchar>(1, 50), 0);
  EXPECT_EQ(r.at<uchar>(1, 70), 255);
  EXPECT_THAT(
      ReliablePixels(candidates, lr, cv::Mat(4, 79, CV_32FC1), 1.0).status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("the fused map must be CV_32FC1")));
}

TEST(ReliabilityTest, BadInputNamesWhatIsWrong) {
  const cv::Mat estimate(8, 32, CV_32FC1, cv::Scalar(10));
  const std::vector<cv::Mat> two = {estimate, estimate};
  EXPECT_THAT(CandidateConfidences(two, {cv::Mat()}, estimate, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("1 left-right masks for 2 candidates")));
  EXPECT_THAT(
      CandidateConfidences({estimate, cv::Mat(8, 31, CV_32FC1)}, {}, estimate,
                           {})
          .status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("fusion: candidate 1 is 31x8, candidate 0 is 32x8")));
  EXPECT_THAT(
      CandidateConfidences(two, {}, cv::Mat(8, 31, CV_32FC1), {}).status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("the estimate must be CV_32FC1")));
  EXPECT_THAT(
      CandidateConfidences(two, {estimate, estimate}, estimate, {}).status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("left-right mask 0 must be CV_8UC1")));
  EXPECT_THAT(
      ConsistentMedian({}, {}, 8).status(),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("no candidate")));
  const cv::Mat view(8, 32, CV_8UC1, cv::Scalar(0));
  EXPECT_THAT(
      FuseByReliability(two, {}, view, cv::Mat(), view, Params(), {}).status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("plane prior: the view must be 8-bit")));
  EXPECT_THAT(
      FuseByReliability(two, {}, view, view, cv::Mat(), Params(), {}).status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("photo-consistency: the views must be")));
  ReliabilityOptions o;
  o.window_fraction = 0;
  EXPECT_THAT(
      FuseByReliability(two, {}, view, view, view, Params(), o).status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("window_fraction is 0")));
}

using O = ReliabilityOptions;

TEST(ReliabilityTest, RulesNameTheirField) {
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.sigma_fraction = 0; }, "sigma_fraction is 0"},
      {[](O& o) { o.sigma_fraction = 0.5; }, "sigma_fraction is 0.5"},
      {[](O& o) { o.window_fraction = 3; }, "window_fraction is 3"},
      {[](O& o) { o.exponent = -1; }, "exponent is -1"},
      {[](O& o) { o.passes = 0; }, "passes is 0"},
      {[](O& o) { o.passes = 11; }, "passes is 11"},
      {[](O& o) { o.planes.min_inliers = 0; }, "planes.min_inliers is 0"},
      {[](O& o) { o.photo.truncation = 0; }, "photo.truncation is 0"},
      {[](O& o) { o.speckles.max_step = 0; }, "speckles.max_step is 0"},
  });
}

TEST(ReliabilityTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<O>({
      {"/enabled", [](O& o) { o.enabled = false; }},
      {"/sigma_fraction", [](O& o) { o.sigma_fraction = 0.01; }},
      {"/window_fraction", [](O& o) { o.window_fraction = 0.2; }},
      {"/exponent", [](O& o) { o.exponent = 1; }},
      {"/passes", [](O& o) { o.passes = 2; }},
      {"/planes", [](O& o) { o.planes.enabled = false; }},
      {"/photo", [](O& o) { o.photo.enabled = false; }},
      {"/speckles", [](O& o) { o.speckles.enabled = false; }},
  });
}

}  // namespace
}  // namespace hdrstereo::fusion
