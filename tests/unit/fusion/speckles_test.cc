// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/speckles.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>

#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::fusion {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::DoubleEq;
using ::testing::HasSubstr;

constexpr double kTau = 1;  // the fusion's at 320 px
constexpr int kMaxDisp = 64;
constexpr float kWall = 20;
const float kNaN = std::numeric_limits<float>::quiet_NaN();

cv::Mat Wall(int width = 320, int height = 240) {
  return cv::Mat(height, width, CV_32FC1, cv::Scalar(kWall));
}

// Pixels of `a` that differ from `b` (NaN equals NaN).
int Differing(const cv::Mat& a, const cv::Mat& b) {
  int n = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      const float u = a.at<float>(y, x), v = b.at<float>(y, x);
      n += !(u == v || (std::isnan(u) && std::isnan(v)));
    }
  }
  return n;
}

TEST(SpeckleTest, IslandsOfAnotherSurfaceTakeTheSurfaceAroundThem) {
  cv::Mat z = Wall();
  z(cv::Rect(50, 50, 3, 3)).setTo(60);   // 9 px
  z(cv::Rect(200, 100, 2, 2)).setTo(2);  // 4 px
  z.at<float>(10, 300) = 45;             // 1 px
  ASSERT_OK_AND_ASSIGN(const SpeckleResult r,
                       RemoveSpeckles(z, kTau, kMaxDisp, {}));
  EXPECT_EQ(Differing(r.disparity, Wall()), 0);
  EXPECT_THAT(r.replaced_fraction, DoubleEq(14.0 / (320 * 240)));
}

TEST(SpeckleTest, ARegionLargerThanTheSizeIsASurfaceAndStays) {
  cv::Mat z = Wall();
  z(cv::Rect(50, 50, 4, 3)).setTo(60);  // 12 px > 10
  ASSERT_OK_AND_ASSIGN(const SpeckleResult r,
                       RemoveSpeckles(z, kTau, kMaxDisp, {}));
  EXPECT_EQ(Differing(r.disparity, z), 0);
  EXPECT_EQ(r.replaced_fraction, 0);
}

TEST(SpeckleTest, TheSizeScalesWithTheArea) {
  // 16 px: a surface at 320 px wide, an island at 640 px (10 x 4 = 40).
  for (const int width : {320, 640}) {
    cv::Mat z = Wall(width, 240);
    z(cv::Rect(50, 50, 4, 4)).setTo(60);
    ASSERT_OK_AND_ASSIGN(const SpeckleResult r,
                         RemoveSpeckles(z, kTau * width / 320, kMaxDisp, {}));
    EXPECT_EQ(Differing(r.disparity, z), width == 320 ? 0 : 16) << width;
  }
}

TEST(SpeckleTest, ASlantedSurfaceSteppingByTwoTauARowIsOneRegion) {
  // A face seen at a grazing angle: six rows, 2 tau apart, above the wall.
  cv::Mat z = Wall();
  for (int row = 0; row < 6; ++row) {
    z(cv::Rect(40, 100 + row, 4, 1)).setTo(kWall + 30 + 2 * row);
  }
  ASSERT_OK_AND_ASSIGN(const SpeckleResult kept,
                       RemoveSpeckles(z, kTau, kMaxDisp, {}));
  EXPECT_EQ(Differing(kept.disparity, z), 0);
  // With neighbours one tau apart at most, each row is an island of 4 px.
  SpeckleOptions strict;
  strict.max_step = 1;
  ASSERT_OK_AND_ASSIGN(const SpeckleResult removed,
                       RemoveSpeckles(z, kTau, kMaxDisp, strict));
  EXPECT_EQ(Differing(removed.disparity, Wall()), 0);
}

TEST(SpeckleTest, AnIslandOnADepthEdgeTakesTheBackground) {
  // A foreground (50) and the wall behind it (20) meet at x = 100; an island
  // of 4 px at disparity 5 on the edge: its row's nearest kept values are
  // 50 and 20, whichever side the foreground is on.
  for (const bool foreground_left : {true, false}) {
    const cv::Range front =
        foreground_left ? cv::Range(0, 100) : cv::Range(100, 320);
    cv::Mat expected = Wall();
    expected.colRange(front).setTo(50);
    cv::Mat z = expected.clone();
    z(cv::Rect(98, 60, 4, 1)).setTo(5);
    ASSERT_OK_AND_ASSIGN(const SpeckleResult r,
                         RemoveSpeckles(z, kTau, kMaxDisp, {}));
    expected(cv::Rect(98, 60, 4, 1)).setTo(kWall);
    EXPECT_EQ(Differing(r.disparity, expected), 0) << foreground_left;
  }
}

TEST(SpeckleTest, InvalidValuesAreInNoRegionAndNeverChanged) {
  cv::Mat z = Wall();
  z(cv::Rect(0, 0, 320, 20)).setTo(kNaN);  // a large invalid band
  z.at<float>(100, 100) = kNaN;            // single invalid pixels
  z.at<float>(100, 200) = -3;              // below the range
  z.at<float>(150, 200) = kMaxDisp + 1;    // above it
  ASSERT_OK_AND_ASSIGN(const SpeckleResult r,
                       RemoveSpeckles(z, kTau, kMaxDisp, {}));
  EXPECT_EQ(Differing(r.disparity, z), 0);
  EXPECT_EQ(r.replaced_fraction, 0);
  // An island bordered only by invalid pixels along its row (and by the
  // wall above and below) is removed, but has nothing to take: it keeps its
  // value.
  cv::Mat row = Wall();
  row.row(60).setTo(kNaN);
  row.at<float>(60, 40) = 30;
  ASSERT_OK_AND_ASSIGN(const SpeckleResult alone,
                       RemoveSpeckles(row, kTau, kMaxDisp, {}));
  EXPECT_EQ(Differing(alone.disparity, row), 0);
  EXPECT_EQ(alone.replaced_fraction, 0);
}

TEST(SpeckleTest, SizeZeroRemovesNothing) {
  cv::Mat z = Wall();
  z.at<float>(10, 10) = 60;
  SpeckleOptions none;
  none.max_size = 0;
  ASSERT_OK_AND_ASSIGN(const SpeckleResult r,
                       RemoveSpeckles(z, kTau, kMaxDisp, none));
  EXPECT_EQ(Differing(r.disparity, z), 0);
}

TEST(SpeckleTest, LargeDisparityRangesKeepTheirSteps) {
  // Beyond 2047 px, 1/16 px steps would not fit 16 bits: at max_disp 30000
  // they are whole pixels. An island 4096 px in front of the wall (x 16: a
  // multiple of 65536, the wall's own value were the steps not reduced) is
  // still found.
  const cv::Mat wall = Wall() + 20000;
  cv::Mat z = wall.clone();
  z(cv::Rect(50, 50, 2, 2)).setTo(20000 + kWall + 4096);
  ASSERT_OK_AND_ASSIGN(const SpeckleResult r,
                       RemoveSpeckles(z, kTau, 30000, {}));
  EXPECT_EQ(Differing(r.disparity, wall), 0);
}

TEST(SpeckleTest, BadInputNamesWhatIsWrong) {
  EXPECT_THAT(RemoveSpeckles(cv::Mat(), kTau, kMaxDisp, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the disparity must be a CV_32FC1 map")));
  EXPECT_THAT(
      RemoveSpeckles(cv::Mat(4, 4, CV_8UC1), kTau, kMaxDisp, {}).status(),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("the disparity must be a CV_32FC1 map")));
  EXPECT_THAT(RemoveSpeckles(Wall(), 0, kMaxDisp, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("tau (0) must be positive and finite")));
  EXPECT_THAT(RemoveSpeckles(Wall(), kTau, 40000, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("max_disp (40000) must be in [1, 32766]")));
  EXPECT_THAT(RemoveSpeckles(Wall(), std::numeric_limits<double>::infinity(),
                             kMaxDisp, {})
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("must be positive and finite")));
  EXPECT_THAT(RemoveSpeckles(cv::Mat(1, 40000, CV_32FC1, cv::Scalar(1)), kTau,
                             kMaxDisp, {})
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the map is 40000 x 1; at most 32767 px")));
  SpeckleOptions o;
  o.max_step = 0;
  EXPECT_THAT(
      RemoveSpeckles(Wall(), kTau, kMaxDisp, o).status(),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("max_step is 0")));
}

using O = SpeckleOptions;

TEST(SpeckleTest, RulesNameTheirField) {
  ExpectRulesNameTheirField<O>({
      {[](O& o) { o.max_size = -1; }, "max_size is -1"},
      {[](O& o) { o.max_size = 2e4; }, "max_size is 20000"},
      {[](O& o) { o.max_step = 0; }, "max_step is 0"},
      {[](O& o) { o.max_step = 101; }, "max_step is 101"},
  });
}

TEST(SpeckleTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<O>({
      {"/enabled", [](O& o) { o.enabled = false; }},
      {"/max_size", [](O& o) { o.max_size = 20; }},
      {"/max_step", [](O& o) { o.max_step = 2; }},
  });
}

}  // namespace
}  // namespace hdrstereo::fusion
