// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/photo_consistency.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
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
constexpr int kHeight = 240;
constexpr float kWall = 4;     // px
constexpr float kSquare = 12;  // px
constexpr int kFattening = 3;  // px the majority's square is too wide
constexpr double kTau = 1;     // the fusion's at 320 px
constexpr int kMaxDisp = 64;
const cv::Rect kSquareRect(120, 80, 80, 80);

// A textured scene (smoothed noise, colour; the square's in other colours
// than the wall's) of a square in front of a wall, seen by both views: the
// truth, the left view, the right view (the left pixels warped by their
// disparity, the nearer surface winning; what only the right view sees is
// new texture; then sensor noise, sigma 2 grey levels) and the left pixels
// the right view sees.
struct Scene {
  cv::Mat truth, left, right, visible;
};

// At every scale the same texture per pixel (a finer one on the larger
// scene): its mean gradient, 4 to 8 grey levels per pixel, must pass the
// texture test (min_texture 4).
cv::Mat Texture(uint64_t seed, int scale) {
  cv::Mat noise(kHeight * scale, kWidth * scale, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(noise, noise, cv::Size(), 0.7);
  return noise;
}

cv::Rect Scaled(const cv::Rect& r, int scale) {
  return {r.x * scale, r.y * scale, r.width * scale, r.height * scale};
}

Scene SquareScene(int scale = 1) {
  Scene s;
  s.truth = cv::Mat(kHeight * scale, kWidth * scale, CV_32FC1,
                    cv::Scalar(kWall * scale));
  s.truth(Scaled(kSquareRect, scale)).setTo(kSquare * scale);
  s.left = Texture(1, scale);
  // The square is another object: its texture in other colours.
  cv::Mat square = s.left(Scaled(kSquareRect, scale));
  cv::multiply(square, cv::Scalar(0.3, 0.6, 1.0), square);
  s.right = Texture(2, scale);
  cv::Mat depth(s.truth.size(), CV_32FC1, cv::Scalar(-1));
  cv::Mat source(s.truth.size(), CV_32SC1, cv::Scalar(-1));
  for (int y = 0; y < s.truth.rows; ++y) {
    for (int x = 0; x < s.truth.cols; ++x) {
      const float d = s.truth.at<float>(y, x);
      const int rx = x - static_cast<int>(d);
      if (rx < 0 || d <= depth.at<float>(y, rx)) continue;
      depth.at<float>(y, rx) = d;
      source.at<int>(y, rx) = x;
      s.right.at<cv::Vec3b>(y, rx) = s.left.at<cv::Vec3b>(y, x);
    }
  }
  cv::Mat noise(s.right.size(), CV_16SC3);
  cv::RNG(4).fill(noise, cv::RNG::NORMAL, 0, 2);
  cv::Mat noisy;
  s.right.convertTo(noisy, CV_16SC3);
  noisy += noise;
  noisy.convertTo(s.right, CV_8UC3);  // saturating
  s.visible = cv::Mat::zeros(s.truth.size(), CV_8UC1);
  for (int y = 0; y < s.truth.rows; ++y) {
    for (int rx = 0; rx < s.truth.cols; ++rx) {
      const int x = source.at<int>(y, rx);
      if (x >= 0) s.visible.at<uint8_t>(y, x) = 255;
    }
  }
  return s;
}

// The way matchers fail at a depth edge: the square kFattening px too wide
// on both sides (their window brings the nearer surface in).
cv::Mat Fattened(const Scene& s, int scale = 1) {
  cv::Mat d(s.truth.size(), CV_32FC1, cv::Scalar(kWall * scale));
  cv::Rect wide = Scaled(kSquareRect, scale);
  wide.x -= kFattening * scale;
  wide.width += 2 * kFattening * scale;
  d(wide).setTo(kSquare * scale);
  return d;
}

// Pixels the right view sees that are more than half a pixel off.
int WrongVisible(const cv::Mat& d, const Scene& s) {
  const cv::Mat wrong = cv::abs(d - s.truth) > 0.5;
  return cv::countNonZero(wrong & s.visible);
}

TEST(PhotoConsistencyTest, TheCandidateTheViewsAgreeWithFixesADepthEdge) {
  for (int scale : {1, 2}) {
    SCOPED_TRACE(scale);
    const Scene s = SquareScene(scale);
    const cv::Mat fused = Fattened(s, scale);
    // Five candidates fail like the fused map, two have the edge right.
    std::vector<cv::Mat> seven(5, fused);
    seven.push_back(s.truth);
    seven.push_back(s.truth);
    ASSERT_OK_AND_ASSIGN(const PhotoConsistencyResult r,
                         ChooseByPhotoConsistency(fused, seven, s.left, s.right,
                                                  kTau * scale, kMaxDisp, {}));
    // The wall pixels the right view sees right of the square (those left
    // of it are occluded): 3 px x 80 rows at 320 px.
    const int before = WrongVisible(fused, s);
    EXPECT_EQ(before, kFattening * scale * kSquareRect.height * scale);
    // Measured: 0 at both sizes.
    EXPECT_LE(WrongVisible(r.disparity, s), before / 10);
    // Nothing right became wrong.
    const cv::Mat was_right = cv::abs(fused - s.truth) <= 0.5;
    EXPECT_EQ(cv::countNonZero((cv::abs(r.disparity - s.truth) > 0.5) &
                               was_right & s.visible),
              0);
    EXPECT_GT(r.replaced_fraction, 0);
  }
}

TEST(PhotoConsistencyTest, AValueNoOtherCandidateSharesIsNotProposed) {
  const Scene s = SquareScene();
  const cv::Mat fused = Fattened(s);
  ASSERT_OK_AND_ASSIGN(const PhotoConsistencyResult alone,
                       ChooseByPhotoConsistency(fused, {fused, s.truth}, s.left,
                                                s.right, kTau, kMaxDisp, {}));
  EXPECT_EQ(cv::countNonZero(alone.disparity != fused), 0);
  // Half a pixel off is still within tau of the truth: the two agree.
  const cv::Mat near = s.truth + 0.5;
  ASSERT_OK_AND_ASSIGN(
      const PhotoConsistencyResult shared,
      ChooseByPhotoConsistency(fused, {fused, s.truth, near}, s.left, s.right,
                               kTau, kMaxDisp, {}));
  EXPECT_LE(WrongVisible(shared.disparity, s), WrongVisible(fused, s) / 10);
  // With min_agreeing 1 a lone value is proposed.
  PhotoConsistencyOptions lone;
  lone.min_agreeing = 1;
  ASSERT_OK_AND_ASSIGN(const PhotoConsistencyResult any,
                       ChooseByPhotoConsistency(fused, {fused, s.truth}, s.left,
                                                s.right, kTau, kMaxDisp, lone));
  EXPECT_LE(WrongVisible(any.disparity, s), WrongVisible(fused, s) / 10);
}

TEST(PhotoConsistencyTest, WithoutTextureNothingChanges) {
  // The scene's texture is 4 to 8 grey levels per pixel: with a threshold
  // above it nothing is textured; with the default the edge is fixed.
  const Scene s = SquareScene();
  const cv::Mat fused = Fattened(s);
  PhotoConsistencyOptions smooth;
  smooth.min_texture = 50;
  ASSERT_OK_AND_ASSIGN(
      const PhotoConsistencyResult r,
      ChooseByPhotoConsistency(fused, {s.truth, s.truth}, s.left, s.right, kTau,
                               kMaxDisp, smooth));
  EXPECT_EQ(cv::countNonZero(r.disparity != fused), 0);
  EXPECT_EQ(r.replaced_fraction, 0);
  ASSERT_OK_AND_ASSIGN(
      const PhotoConsistencyResult textured,
      ChooseByPhotoConsistency(fused, {s.truth, s.truth}, s.left, s.right, kTau,
                               kMaxDisp, {}));
  EXPECT_GT(textured.replaced_fraction, 0);
}

TEST(PhotoConsistencyTest, AFusedValueWithoutAPartnerInTheRightViewIsKept) {
  // 30 px on the first 20 columns sends every window there out of the right
  // view (x - 30 < 0): no evidence for or against it.
  const Scene s = SquareScene();
  cv::Mat fused = Fattened(s);
  fused.colRange(0, 20).setTo(30);
  ASSERT_OK_AND_ASSIGN(
      const PhotoConsistencyResult r,
      ChooseByPhotoConsistency(fused, {s.truth, s.truth}, s.left, s.right, kTau,
                               kMaxDisp, {}));
  EXPECT_EQ(cv::countNonZero(r.disparity.colRange(0, 20) != 30), 0);
  EXPECT_GT(r.replaced_fraction, 0);  // the square's edge, as elsewhere
}

TEST(PhotoConsistencyTest, ACandidateMustBeatTheFusedValueByTheRatio) {
  // The right candidate costs the sensor noise, the fused value's the
  // texture's difference: far more than a millionth of it.
  const Scene s = SquareScene();
  PhotoConsistencyOptions strict;
  strict.max_cost_ratio = 1e-6;
  const cv::Mat fused = Fattened(s);
  ASSERT_OK_AND_ASSIGN(
      const PhotoConsistencyResult kept,
      ChooseByPhotoConsistency(fused, {s.truth, s.truth}, s.left, s.right, kTau,
                               kMaxDisp, strict));
  EXPECT_EQ(cv::countNonZero(kept.disparity != fused), 0);
  EXPECT_EQ(kept.replaced_fraction, 0);
}

TEST(PhotoConsistencyTest, InvalidValuesAreNeverChosenNorReplaced) {
  const Scene s = SquareScene();
  cv::Mat fused = Fattened(s);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  fused.col(kSquareRect.x + kSquareRect.width + 1).setTo(nan);
  const cv::Mat invalid(fused.size(), CV_32FC1, cv::Scalar(nan));
  ASSERT_OK_AND_ASSIGN(
      const PhotoConsistencyResult r,
      ChooseByPhotoConsistency(fused, {invalid, s.truth, s.truth}, s.left,
                               s.right, kTau, kMaxDisp, {}));
  // NaN compares unequal to itself: the column is still NaN, and nothing
  // else became NaN.
  const cv::Mat column = r.disparity.col(kSquareRect.x + kSquareRect.width + 1);
  EXPECT_EQ(cv::countNonZero(column == column), 0);
  EXPECT_EQ(cv::countNonZero(r.disparity == r.disparity),
            cv::countNonZero(fused == fused));
  EXPECT_GT(r.replaced_fraction, 0);  // the truth candidate was used
}

TEST(PhotoConsistencyTest, ValuesOutsideTheRangeAreNeitherProposedNorReplaced) {
  // With the largest disparity 10, the square's 12 px is outside: the fused
  // band that carries it stays (though the truth's wall value would fix
  // it), and two candidates sharing 20 px are never proposed.
  const Scene s = SquareScene();
  const cv::Mat fused = Fattened(s);
  const cv::Mat beyond(fused.size(), CV_32FC1, cv::Scalar(20));
  ASSERT_OK_AND_ASSIGN(
      const PhotoConsistencyResult r,
      ChooseByPhotoConsistency(fused, {s.truth, s.truth, beyond, beyond},
                               s.left, s.right, kTau, 10, {}));
  EXPECT_EQ(cv::countNonZero(r.disparity != fused), 0);
  EXPECT_EQ(r.replaced_fraction, 0);
}

TEST(PhotoConsistencyTest, BadInputNamesWhatIsWrong) {
  const Scene s = SquareScene();
  const cv::Mat fused = Fattened(s);
  EXPECT_THAT(ChooseByPhotoConsistency(cv::Mat(), {fused}, s.left, s.right,
                                       kTau, kMaxDisp, {})
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the disparity must be a CV_32FC1 map")));
  EXPECT_THAT(
      ChooseByPhotoConsistency(fused, {}, s.left, s.right, kTau, kMaxDisp, {})
          .status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("0 candidates; 1 to 64 are allowed")));
  EXPECT_THAT(ChooseByPhotoConsistency(fused, {fused, fused.colRange(0, 8)},
                                       s.left, s.right, kTau, kMaxDisp, {})
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("candidate 1 must be CV_32FC1")));
  cv::Mat grey;
  cv::cvtColor(s.right, grey, cv::COLOR_BGR2GRAY);
  EXPECT_THAT(ChooseByPhotoConsistency(fused, {fused, fused}, s.left, grey,
                                       kTau, kMaxDisp, {})
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the views must be a pair of 8-bit images")));
  EXPECT_THAT(
      ChooseByPhotoConsistency(fused, {fused, fused}, s.left,
                               s.right.colRange(0, 8), kTau, kMaxDisp, {})
          .status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("of the map's size")));
  PhotoConsistencyOptions o;
  o.window_radius = 0;
  EXPECT_THAT(ChooseByPhotoConsistency(fused, {fused}, s.left, s.right, kTau,
                                       kMaxDisp, o)
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("window_radius is 0")));
  EXPECT_THAT(
      ChooseByPhotoConsistency(fused, {fused}, s.left, s.right, 0, kMaxDisp, {})
          .status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("tau (0) must be positive")));
  EXPECT_THAT(
      ChooseByPhotoConsistency(fused, {fused}, s.left, s.right, kTau, 0, {})
          .status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("max_disp (0) in [1, ")));
  PhotoConsistencyOptions eight;
  eight.min_agreeing = 8;
  EXPECT_THAT(ChooseByPhotoConsistency(fused, {fused, fused}, s.left, s.right,
                                       kTau, kMaxDisp, eight)
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("min_agreeing (8) exceeds the 2 candidates")));
}

using O = PhotoConsistencyOptions;

TEST(PhotoConsistencyTest, RulesNameTheirField) {
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.window_radius = 33; }, "window_radius is 33"},
      {[](O& o) { o.colour_sigma = 0; }, "colour_sigma is 0"},
      {[](O& o) { o.truncation = 2; }, "truncation is 2"},
      {[](O& o) { o.min_texture = -1; }, "min_texture is -1"},
      {[](O& o) { o.max_cost_ratio = 0; }, "max_cost_ratio is 0"},
      {[](O& o) { o.max_cost_ratio = 1.5; }, "max_cost_ratio is 1.5"},
      {[](O& o) { o.min_agreeing = 0; }, "min_agreeing is 0"},
  });
}

TEST(PhotoConsistencyTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<O>({
      {"/enabled", [](O& o) { o.enabled = false; }},
      {"/window_radius", [](O& o) { o.window_radius = 2; }},
      {"/colour_sigma", [](O& o) { o.colour_sigma = 0.2; }},
      {"/truncation", [](O& o) { o.truncation = 0.05; }},
      {"/min_texture", [](O& o) { o.min_texture = 2; }},
      {"/max_cost_ratio", [](O& o) { o.max_cost_ratio = 0.8; }},
      {"/min_agreeing", [](O& o) { o.min_agreeing = 1; }},
  });
}

}  // namespace
}  // namespace hdrstereo::fusion
