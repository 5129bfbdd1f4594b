// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/plane_prior.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::fusion {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

constexpr int kWidth = 320;
constexpr int kHeight = 240;
constexpr double kTau = 1.0;  // sigma_fraction x width at 320 px
constexpr int kMaxDisp = 64;
// The surface under test, and its inside (away from the segment's edge,
// which the segmentation may give to either side).
const cv::Rect kSurface(100, 60, 120, 120);
const cv::Rect kInside(104, 64, 112, 112);

// The images below at `scale` times 320 x 240 (the surface scaled too).
cv::Rect Scaled(const cv::Rect& r, int scale) {
  return {r.x * scale, r.y * scale, r.width * scale, r.height * scale};
}

// A slanted surface: 20 px at its left edge, 6 px more at its right, 1.2 px
// more at its bottom than at its top (times `scale`).
double Slanted(int x, int y, int scale = 1) {
  const cv::Rect r = Scaled(kSurface, scale);
  return 20.0 * scale + 0.05 * (x - r.x) + 0.01 * (y - r.y);
}

// A wall of strong texture (uniform noise, grey levels 0..255 in every
// channel) with the surface drawn on it, untextured (one colour) or
// textured like the wall.
cv::Mat View(bool textured_surface, int scale = 1, int type = CV_8UC1) {
  cv::Mat view(kHeight * scale, kWidth * scale, type);
  cv::RNG rng(3);
  rng.fill(view, cv::RNG::UNIFORM, 0, 256);
  if (!textured_surface)
    view(Scaled(kSurface, scale)).setTo(cv::Scalar(60, 90, 120));
  return view;
}

// The fused map: the wall at 10 px, the surface at its true disparity,
// except its top quarter, where the wall's disparity has bled in -- the way
// candidates fail on a surface without texture.
cv::Mat Bled(int scale = 1) {
  cv::Mat d(kHeight * scale, kWidth * scale, CV_32FC1, cv::Scalar(10));
  const cv::Rect r = Scaled(kSurface, scale);
  for (int y = r.y; y < r.br().y; ++y) {
    for (int x = r.x; x < r.br().x; ++x) {
      const bool bled = y < r.y + r.height / 4;
      d.at<float>(y, x) =
          bled ? 10.0f : static_cast<float>(Slanted(x, y, scale));
    }
  }
  return d;
}

// The largest distance of `disparity` from the slanted surface inside it.
double WorstOffTheSurface(const cv::Mat& disparity, int scale) {
  const cv::Rect inside = Scaled(kInside, scale);
  double worst = 0;
  for (int y = inside.y; y < inside.br().y; ++y) {
    for (int x = inside.x; x < inside.br().x; ++x) {
      worst = std::max(
          worst, std::abs(disparity.at<float>(y, x) - Slanted(x, y, scale)));
    }
  }
  return worst;
}

// Every pixel reliable.
cv::Mat AllReliable(int scale = 1) {
  return cv::Mat(kHeight * scale, kWidth * scale, CV_8UC1, cv::Scalar(255));
}

TEST(PlanePriorTest, AnUntexturedSurfaceTakesThePlaneOfItsReliablePixels) {
  const cv::Mat fused = Bled();
  ASSERT_OK_AND_ASSIGN(
      const PlanePriorResult r,
      ApplyPlanePrior(fused, AllReliable(), View(false), kTau, kMaxDisp, {}));
  ASSERT_EQ(r.disparity.type(), CV_32FC1);
  // The bled quarter and the rest of the surface are on the plane.
  EXPECT_LT(WorstOffTheSurface(r.disparity, 1), 0.01);
  // The textured wall keeps its disparities, and only the surface (its
  // area is 18.75 % of the image) changed.
  cv::Mat wall = cv::Mat::ones(kHeight, kWidth, CV_8UC1);
  wall(cv::Rect(96, 56, 128, 128)).setTo(0);
  EXPECT_EQ(cv::countNonZero((r.disparity != fused) & wall), 0);
  EXPECT_EQ(r.planes, 1);
  EXPECT_GT(r.segments, 1);
  EXPECT_NEAR(r.replaced_fraction, 0.1875, 0.01);
}

TEST(PlanePriorTest, AColourViewAtTwiceTheSize) {
  // 640 x 480: tau 2 px, segment sizes doubled, a BGR view.
  const cv::Mat fused = Bled(2);
  ASSERT_OK_AND_ASSIGN(
      const PlanePriorResult r,
      ApplyPlanePrior(fused, AllReliable(2), View(false, 2, CV_8UC3), 2 * kTau,
                      2 * kMaxDisp, {}));
  EXPECT_LT(WorstOffTheSurface(r.disparity, 2), 0.01);
  EXPECT_EQ(r.planes, 1);
  EXPECT_NEAR(r.replaced_fraction, 0.1875, 0.01);
}

TEST(PlanePriorTest, ATexturedSurfaceKeepsItsDisparities) {
  // The matchers have evidence there: the bled quarter is theirs to fix.
  const cv::Mat fused = Bled();
  ASSERT_OK_AND_ASSIGN(
      const PlanePriorResult r,
      ApplyPlanePrior(fused, AllReliable(), View(true), kTau, kMaxDisp, {}));
  EXPECT_EQ(cv::countNonZero(r.disparity != fused), 0);
  EXPECT_EQ(r.planes, 0);
  EXPECT_EQ(r.replaced_fraction, 0);
}

TEST(PlanePriorTest, ASegmentNoPlaneExplainsKeepsItsDisparities) {
  // Two surfaces (20 and 40 px, left and right half) that look the same:
  // one segment, which no plane fits within tau on 70 % of its pixels.
  cv::Mat fused(kHeight, kWidth, CV_32FC1, cv::Scalar(10));
  fused(kSurface).setTo(20);
  fused(cv::Rect(160, 60, 60, 120)).setTo(40);
  ASSERT_OK_AND_ASSIGN(
      const PlanePriorResult r,
      ApplyPlanePrior(fused, AllReliable(), View(false), kTau, kMaxDisp, {}));
  EXPECT_EQ(cv::countNonZero(r.disparity != fused), 0);
  // With the rule relaxed to 40 %, one of the two surfaces' planes is
  // taken: the rule is what kept them.
  PlanePriorOptions loose;
  loose.min_inliers = 0.4;
  ASSERT_OK_AND_ASSIGN(const PlanePriorResult l,
                       ApplyPlanePrior(fused, AllReliable(), View(false), kTau,
                                       kMaxDisp, loose));
  EXPECT_EQ(l.planes, 1);
  EXPECT_GT(cv::countNonZero(l.disparity(kInside) != fused(kInside)), 0);
}

TEST(PlanePriorTest, TooFewReliablePixelsKeepTheDisparities) {
  const cv::Mat fused = Bled();
  // Reliable on the surface's top 20 % only (min_support is 30 %), all of
  // it in the bled quarter.
  cv::Mat reliable = AllReliable();
  reliable(cv::Rect(kSurface.x, kSurface.y + 24, kSurface.width, 96)).setTo(0);
  ASSERT_OK_AND_ASSIGN(
      const PlanePriorResult r,
      ApplyPlanePrior(fused, reliable, View(false), kTau, kMaxDisp, {}));
  EXPECT_EQ(cv::countNonZero(r.disparity != fused), 0);
  // Without that rule the surface would take the bled pixels' plane: the
  // reliable pixels are the prior's only evidence.
  PlanePriorOptions loose;
  loose.min_support = 0.1;
  ASSERT_OK_AND_ASSIGN(
      const PlanePriorResult l,
      ApplyPlanePrior(fused, reliable, View(false), kTau, kMaxDisp, loose));
  EXPECT_EQ(l.planes, 1);
  EXPECT_NEAR(l.disparity.at<float>(kInside.br().y - 1, kInside.x), 10, 0.01);
}

TEST(PlanePriorTest, PlanesStayInTheDisparityRange) {
  // A steep reliable surface whose plane leaves [0, max_disp] inside it.
  cv::Mat fused(kHeight, kWidth, CV_32FC1, cv::Scalar(10));
  for (int y = kSurface.y; y < kSurface.br().y; ++y) {
    for (int x = kSurface.x; x < kSurface.br().x; ++x) {
      fused.at<float>(y, x) = static_cast<float>(x - kSurface.x) - 20.0f;
    }
  }
  fused(kSurface).setTo(std::nanf(""), fused(kSurface) < 0);
  ASSERT_OK_AND_ASSIGN(
      const PlanePriorResult r,
      ApplyPlanePrior(fused, AllReliable(), View(false), kTau, kMaxDisp, {}));
  ASSERT_EQ(r.planes, 1);
  double lo = 0, hi = 0;
  cv::minMaxLoc(r.disparity(kInside), &lo, &hi);
  EXPECT_EQ(lo, 0);
  EXPECT_EQ(hi, kMaxDisp);
}

TEST(PlanePriorTest, BadInputNamesWhatIsWrong) {
  const cv::Mat d(8, 32, CV_32FC1, cv::Scalar(1));
  const cv::Mat mask(8, 32, CV_8UC1, cv::Scalar(255));
  EXPECT_THAT(ApplyPlanePrior(cv::Mat(), mask, mask, 1, 8, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the disparity must be a CV_32FC1 map")));
  EXPECT_THAT(
      ApplyPlanePrior(d, cv::Mat(8, 31, CV_8UC1), mask, 1, 8, {}).status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("the reliable mask must be CV_8UC1")));
  EXPECT_THAT(ApplyPlanePrior(d, mask, d, 1, 8, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the view must be 8-bit")));
  EXPECT_THAT(ApplyPlanePrior(d, mask, mask, 0, 8, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("tau (0) and max_disp (8) must be positive")));
  PlanePriorOptions o;
  o.min_inliers = 0;
  EXPECT_THAT(ApplyPlanePrior(d, mask, mask, 1, 8, o).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("min_inliers is 0")));
}

using O = PlanePriorOptions;

TEST(PlanePriorTest, RulesNameTheirField) {
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.segment_k = 0; }, "segment_k is 0"},
      {[](O& o) { o.segment_sigma = -1; }, "segment_sigma is -1"},
      {[](O& o) { o.min_segment_pixels = 2; }, "min_segment_pixels is 2"},
      {[](O& o) { o.max_texture = -1; }, "max_texture is -1"},
      {[](O& o) { o.min_support = 0; }, "min_support is 0"},
      {[](O& o) { o.min_inliers = 1.5; }, "min_inliers is 1.5"},
      {[](O& o) { o.ransac_iterations = 0; }, "ransac_iterations is 0"},
  });
}

TEST(PlanePriorTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<O>({
      {"/enabled", [](O& o) { o.enabled = false; }},
      {"/segment_k", [](O& o) { o.segment_k = 100; }},
      {"/segment_sigma", [](O& o) { o.segment_sigma = 0.8; }},
      {"/min_segment_pixels", [](O& o) { o.min_segment_pixels = 100; }},
      {"/max_texture", [](O& o) { o.max_texture = 1; }},
      {"/min_support", [](O& o) { o.min_support = 0.5; }},
      {"/min_inliers", [](O& o) { o.min_inliers = 0.9; }},
      {"/ransac_iterations", [](O& o) { o.ransac_iterations = 50; }},
  });
}

}  // namespace
}  // namespace hdrstereo::fusion
