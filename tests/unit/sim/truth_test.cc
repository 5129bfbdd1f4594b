// SPDX-License-Identifier: GPL-3.0-or-later
//
// Ground truth against closed-form geometry (never against the renderer
// itself).
#include "hardware/sim/truth.h"

#include <gtest/gtest.h>

#include <cmath>

#include "hardware/sim/render.h"
#include "tests/unit/sim/test_scenes.h"

namespace hdrstereo::sim {
namespace {

using ::hdrstereo::sim::testing::kCx;
using ::hdrstereo::sim::testing::kCy;
using ::hdrstereo::sim::testing::kF;
using ::hdrstereo::sim::testing::ParseOrDie;
using ::hdrstereo::sim::testing::SmallSceneJson;

constexpr double kMaxDisparityError = 1e-3;  // px

StereoTruth TruthOrDie(const Scene& scene, double left_mm, double baseline) {
  Renderer renderer(scene);
  absl::StatusOr<StereoTruth> truth =
      ComputeStereoTruth(renderer, left_mm, baseline);
  EXPECT_TRUE(truth.ok()) << truth.status();
  return truth.ok() ? *truth : StereoTruth();
}

TEST(TruthTest, FrontoParallelPlaneHasDisparityFBOverZ) {
  constexpr double kZ = 1000;
  Scene scene = ParseOrDie(SmallSceneJson(
      R"({"type": "plane", "center_mm": [0, 0, 1000], "normal": [0, 0, -1]})"));
  for (double left : {0.0, 20.0}) {
    for (double baseline : {75.0, 130.0}) {
      StereoTruth t = TruthOrDie(scene, left, baseline);
      const double expected = kF * baseline / kZ;
      for (const ViewTruth* v : {&t.left, &t.right}) {
        ASSERT_EQ(v->disparity.size(), cv::Size(160, 120));
        for (int y = 0; y < 120; ++y) {
          for (int x = 0; x < 160; ++x) {
            ASSERT_NEAR(v->disparity.at<float>(y, x), expected,
                        kMaxDisparityError)
                << "x=" << x << " y=" << y << " baseline=" << baseline;
            ASSERT_NEAR(v->depth.at<float>(y, x), kZ, 1e-3);
            ASSERT_EQ(v->disparity_y.at<float>(y, x), 0.0f);
          }
        }
      }
    }
  }
}

// Plane Z = Z0 + a X + b Y. Left view: d = f B / Z0 * (1 - a x' - b y') with
// x' = (u - cx) / f, y' = (v - cy) / f. Right view (camera at X = B):
// d = f B (1 - a x' - b y') / (Z0 + a B).
TEST(TruthTest, SlantedPlaneHasAnalyticLinearDisparity) {
  constexpr double kZ0 = 1000, kA = 0.3, kB = 0.1, kBase = 150;
  Scene scene = ParseOrDie(SmallSceneJson(
      R"({"type": "plane", "center_mm": [0, 0, 1000],
          "normal": [-0.3, -0.1, 1]})"));
  StereoTruth t = TruthOrDie(scene, 0, kBase);
  double max_err_left = 0, max_err_right = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const double xn = (x - kCx) / kF, yn = (y - kCy) / kF;
      const double left = kF * kBase / kZ0 * (1 - kA * xn - kB * yn);
      const double right =
          kF * kBase * (1 - kA * xn - kB * yn) / (kZ0 + kA * kBase);
      max_err_left = std::max(
          max_err_left, std::abs(t.left.disparity.at<float>(y, x) - left));
      max_err_right = std::max(
          max_err_right, std::abs(t.right.disparity.at<float>(y, x) - right));
    }
  }
  EXPECT_LT(max_err_left, kMaxDisparityError);
  EXPECT_LT(max_err_right, kMaxDisparityError);
}

// A stage axis tilted by dy per mm moves the right camera by
// T = B * (1, dy, 0) / |(1, dy, 0)|: d_x = f Tx / Z, d_y = -f Ty / Z.
TEST(TruthTest, MisalignedStageAxisAddsVerticalDisparity) {
  constexpr double kZ = 1000, kDy = 0.02, kBase = 150;
  Scene scene = ParseOrDie(SmallSceneJson(
      R"({"type": "plane", "center_mm": [0, 0, 1000], "normal": [0, 0, -1]})",
      R"("rig": {"misalignment": {"axis_dy_per_mm": 0.02}})"));
  ASSERT_FALSE(scene.rig.IsIdeal());
  StereoTruth t = TruthOrDie(scene, 0, kBase);
  const double norm = std::sqrt(1 + kDy * kDy);
  const double tx = kBase / norm, ty = kBase * kDy / norm;
  for (int y = 0; y < 120; y += 7) {
    for (int x = 0; x < 160; x += 7) {
      EXPECT_NEAR(t.left.disparity.at<float>(y, x), kF * tx / kZ,
                  kMaxDisparityError);
      EXPECT_NEAR(t.left.disparity_y.at<float>(y, x), -kF * ty / kZ,
                  kMaxDisparityError);
    }
  }
}

// A card (|X| <= 100 mm at Z = 1000) in front of a wall at Z = 2000, views at
// X = 0 and X = 150. Wall points the left camera sees but the card hides from
// the right camera: X_wall in [-350, -200), i.e. u = X / 10 + cx in
// [44.5, 59.5).
TEST(TruthTest, OcclusionMaskMatchesGeometry) {
  Scene scene = ParseOrDie(SmallSceneJson(
      R"({"name": "wall", "type": "plane", "center_mm": [0, 0, 2000],
          "normal": [0, 0, -1]},
         {"name": "card", "type": "plane", "center_mm": [0, 0, 1000],
          "normal": [0, 0, -1], "u_axis": [1, 0, 0],
          "size_mm": [200, 10000]})"));
  StereoTruth t = TruthOrDie(scene, 0, 150);
  int occluded = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const double u = x;
      const double wall_x = (u - kCx) * 2000 / kF;
      const double card_x = (u - kCx) * 1000 / kF;
      const uint8_t vis = t.left.nonoccluded.at<uint8_t>(y, x);
      if (std::abs(card_x) < 100 - 5) {
        // The card is seen; the right view at X = 150 also sees the card
        // point if it is inside the right image (it is, for these pixels).
        EXPECT_EQ(vis, 255) << "card pixel x=" << x;
      } else if (std::abs(card_x) > 100 + 5) {
        const bool hidden = wall_x >= -350 && wall_x < -200;
        // Skip pixels within 1 px of the occlusion edges.
        if (std::abs(u - 44.5) < 1 || std::abs(u - 59.5) < 1) continue;
        // Right view must contain the point: u_right = u - f * 150 / 2000.
        if (u - kF * 150 / 2000 < 0) continue;
        EXPECT_EQ(vis, hidden ? 0 : 255) << "wall pixel x=" << x;
        occluded += hidden ? 1 : 0;
      }
    }
  }
  EXPECT_GT(occluded, 120 * 10);  // about 13 columns of 120 rows
}

TEST(TruthTest, RejectsPositionsOutsideTravel) {
  Scene scene = ParseOrDie(SmallSceneJson(
      R"({"type": "plane", "center_mm": [0, 0, 1000], "normal": [0, 0, -1]})"));
  Renderer renderer(scene);
  EXPECT_EQ(ComputeStereoTruth(renderer, 100, 75).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeStereoTruth(renderer, 0, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace hdrstereo::sim
