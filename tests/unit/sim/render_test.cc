// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/render.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "absl/strings/str_cat.h"
#include "hardware/sim/sim_world.h"
#include "tests/support/status_matchers.h"
#include "tests/unit/sim/test_scenes.h"

namespace hdrstereo::sim {
namespace {

using ::hdrstereo::sim::testing::kCx;
using ::hdrstereo::sim::testing::kCy;
using ::hdrstereo::sim::testing::kF;
using ::hdrstereo::sim::testing::ParseOrDie;
using ::hdrstereo::sim::testing::SmallBundledScene;
using ::hdrstereo::sim::testing::SmallSceneJson;

double Luminance(const cv::Vec3f& bgr) {
  return 0.0722 * bgr[0] + 0.7152 * bgr[1] + 0.2126 * bgr[2];
}

// Thesis chapter 3: the lamp saturates the longest exposure (1/15 s) but not
// the shortest (1/2000 s); the radiance spans >= 5000:1.
TEST(RenderTest, LabLampSaturatesOnlyLongExposuresAndIsHdr) {
  SimWorld world(SmallBundledScene("lab-lamp"));
  const int lamp = world.scene().FindObject("lamp");
  ASSERT_GE(lamp, 0);
  RadianceFrame truth = world.RenderRadiance();
  const cv::Mat lamp_mask = truth.object_id == lamp + 1;
  const int lamp_pixels = cv::countNonZero(lamp_mask);
  ASSERT_GT(lamp_pixels, 50);

  cv::Mat longest = world.RenderExposure({1.0 / 15, 100});
  cv::Mat shortest = world.RenderExposure({1.0 / 2000, 100});
  int saturated_long = 0;
  uint8_t max_short = 0;
  for (int y = 0; y < longest.rows; ++y) {
    for (int x = 0; x < longest.cols; ++x) {
      if (!lamp_mask.at<uint8_t>(y, x)) continue;
      const cv::Vec3b l = longest.at<cv::Vec3b>(y, x);
      const cv::Vec3b s = shortest.at<cv::Vec3b>(y, x);
      saturated_long += (l[0] == 255 && l[1] == 255 && l[2] == 255) ? 1 : 0;
      max_short = std::max({max_short, s[0], s[1], s[2]});
    }
  }
  EXPECT_EQ(saturated_long, lamp_pixels);  // every lamp pixel, every channel
  EXPECT_LT(max_short, 255);
  EXPECT_GT(max_short, 128);  // and it is still bright at 1/2000 s

  double lo = 1e30, hi = 0;
  for (int y = 0; y < truth.radiance.rows; ++y) {
    for (int x = 0; x < truth.radiance.cols; ++x) {
      const double l = Luminance(truth.radiance.at<cv::Vec3f>(y, x));
      lo = std::min(lo, l);
      hi = std::max(hi, l);
    }
  }
  ASSERT_GT(lo, 0.0) << "every pixel sees a lit surface";
  EXPECT_GE(hi / lo, 5000.0) << "hi=" << hi << " lo=" << lo;
}

// The projector at X = 100 mm looks along +z at a wall at Z = 1000. A camera
// pixel (u, v) sees X = (u - cx) Z / f, which the projector maps to column
// x_p = f_p (X - 100) / Z + cx_p, lit by pattern column round(x_p).
constexpr double kProjX = 100, kWallZ = 1000;
constexpr int kProjW = 256, kProjH = 64, kBits = 8;

std::string ProjectorSceneJson(const std::string& extra_objects) {
  return SmallSceneJson(absl::StrCat(R"({"name": "wall", "type": "plane",
                       "center_mm": [0, 0, 1000], "normal": [0, 0, -1]})",
                                     extra_objects),
                        R"("projector": {"position_mm": [100, 0, 0],
                       "look_at_mm": [100, 0, 1000], "width": 256,
                       "height": 64, "fov_deg": 40, "max_intensity_cd": 400,
                       "black_level": 0.05, "gamma": 2.2})");
}

cv::Mat GrayCodeColumns(int bit, bool inverse) {
  cv::Mat p(kProjH, kProjW, CV_8UC1);
  for (int c = 0; c < kProjW; ++c) {
    const int gray = c ^ (c >> 1);
    const bool on = ((gray >> (kBits - 1 - bit)) & 1) != inverse;
    p.col(c).setTo(on ? 255 : 0);
  }
  return p;
}

TEST(RenderTest, ProjectorColumnsDecodeToAnalyticColumns) {
  Renderer renderer(ParseOrDie(ProjectorSceneJson("")));
  const View view = CameraView(renderer.scene(), 0);
  const double fp = (kProjW / 2.0) / std::tan(20.0 * M_PI / 180.0);
  const double cxp = (kProjW - 1) / 2.0;
  cv::Mat code(120, 160, CV_32SC1, cv::Scalar(0));
  for (int bit = 0; bit < kBits; ++bit) {
    const cv::Mat on =
        renderer.Render(view, GrayCodeColumns(bit, false)).radiance;
    const cv::Mat off =
        renderer.Render(view, GrayCodeColumns(bit, true)).radiance;
    for (int y = 0; y < 120; ++y) {
      for (int x = 0; x < 160; ++x) {
        const int b = on.at<cv::Vec3f>(y, x)[1] > off.at<cv::Vec3f>(y, x)[1];
        code.at<int>(y, x) = (code.at<int>(y, x) << 1) | b;
      }
    }
  }
  int checked = 0, wrong = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const double wall_x = (x - kCx) * kWallZ / kF;
      const double xp = fp * (wall_x - kProjX) / kWallZ + cxp;
      const double col = std::floor(xp + 0.5);
      const double wall_y = (y - kCy) * kWallZ / kF;
      const double row =
          std::floor(fp * wall_y / kWallZ + (kProjH - 1) / 2.0 + 0.5);
      if (col < 0 || col >= kProjW || row < 0 || row >= kProjH) continue;
      if (std::abs(xp - std::floor(xp) - 0.5) < 1e-3) continue;  // a boundary
      int gray = code.at<int>(y, x), binary = 0;
      for (; gray; gray >>= 1) binary ^= gray;
      ++checked;
      if (binary != static_cast<int>(col)) {
        if (++wrong < 5) {
          ADD_FAILURE() << "x=" << x << " y=" << y << " decoded " << binary
                        << " expected " << col << " (x_p=" << xp << ")";
        }
      }
    }
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(checked, 160 * 120 / 8);  // the projector's 256 x 64 strip
}

// A ball on the projector's axis shadows the wall: wall points whose segment
// to the projector passes within the radius get no projector light at all.
TEST(RenderTest, ProjectorShadowsGetNoProjectorLight) {
  constexpr double kBallZ = 500, kRadius = 50;
  Renderer renderer(ParseOrDie(ProjectorSceneJson(
      R"(, {"name": "ball", "type": "sphere", "center_mm": [100, 0, 500],
            "radius_mm": 50})")));
  const View view = CameraView(renderer.scene(), 0);
  const cv::Mat white(kProjH, kProjW, CV_8UC1, cv::Scalar(255));
  const cv::Mat lit = renderer.Render(view, white).radiance;
  const cv::Mat dark = renderer.Render(view, cv::Mat()).radiance;  // off
  const Vec3 ball(kProjX, 0, kBallZ), projector(kProjX, 0, 0);
  int shadowed = 0, lit_count = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const Vec3 ray((x - kCx) / kF, (y - kCy) / kF, 1);
      // Does the camera ray hit the ball first? (|ray x ball|^2 < r^2 |ray|^2)
      const double miss2 = ray.cross(ball).dot(ray.cross(ball)) / ray.dot(ray);
      if (miss2 < (kRadius + 2) * (kRadius + 2)) continue;
      const Vec3 wall = ray * kWallZ;
      // Distance from the ball centre to the segment wall -> projector.
      const Vec3 d = projector - wall;
      const double s = std::clamp((ball - wall).dot(d) / d.dot(d), 0.0, 1.0);
      const double dist = cv::norm(wall + s * d - ball);
      const cv::Vec3f a = lit.at<cv::Vec3f>(y, x), b = dark.at<cv::Vec3f>(y, x);
      if (dist < kRadius - 0.5) {
        EXPECT_EQ(a, b) << "shadowed pixel x=" << x << " y=" << y;
        ++shadowed;
      } else if (dist > kRadius + 0.5) {
        // Inside the projector frustum (x_p within the image)?
        const double fp = (kProjW / 2.0) / std::tan(20.0 * M_PI / 180.0);
        const double xp = fp * (wall[0] - kProjX) / kWallZ + (kProjW - 1) / 2.0;
        const double yp = fp * wall[1] / kWallZ + (kProjH - 1) / 2.0;
        if (xp < 0 || xp > kProjW - 1 || yp < 0 || yp > kProjH - 1) continue;
        EXPECT_GT(a[1], b[1] * 1.5f) << "lit pixel x=" << x << " y=" << y;
        ++lit_count;
      }
    }
  }
  EXPECT_GT(shadowed, 100);
  EXPECT_GT(lit_count, 1000);
}

TEST(RenderTest, ProjectorBlackLevelAndGamma) {
  Renderer renderer(ParseOrDie(ProjectorSceneJson("")));
  const View view = CameraView(renderer.scene(), 0);
  auto green_at_center = [&](const cv::Mat& pattern) {
    return static_cast<double>(
        renderer.Render(view, pattern).radiance.at<cv::Vec3f>(60, 100)[1]);
  };
  const double off = green_at_center(cv::Mat());
  const double black = green_at_center(cv::Mat(kProjH, kProjW, CV_8UC1, 0.0));
  const double half = green_at_center(cv::Mat(kProjH, kProjW, CV_32FC1, 0.5));
  const double white = green_at_center(cv::Mat(kProjH, kProjW, CV_8UC1, 255.0));
  // emitted = black + (1 - black) v^gamma, with black = 0.05, gamma = 2.2.
  const double unit = white - off;
  ASSERT_GT(unit, 0);
  EXPECT_NEAR((black - off) / unit, 0.05, 1e-5);
  EXPECT_NEAR((half - off) / unit, 0.05 + 0.95 * std::pow(0.5, 2.2), 1e-5);
}

// The bundled "shadowed" scene leaves projector shadows in view.
TEST(RenderTest, ShadowedSceneHasProjectorShadowsInView) {
  SimWorld world(SmallBundledScene("shadowed"));
  world.ProjectorOff();
  const cv::Mat off = world.RenderRadiance().radiance;
  const ProjectorModel& p = world.scene().projector;
  ASSERT_TRUE(world
                  .SetProjectorPattern(
                      cv::Mat(p.height, p.width, CV_8UC1, cv::Scalar(255)))
                  .ok());
  const cv::Mat on = world.RenderRadiance().radiance;
  int same = 0, brighter = 0;
  for (int y = 0; y < on.rows; ++y) {
    for (int x = 0; x < on.cols; ++x) {
      const cv::Vec3f a = on.at<cv::Vec3f>(y, x), b = off.at<cv::Vec3f>(y, x);
      same += a == b;
      brighter += a[1] > b[1];
    }
  }
  const int n = on.rows * on.cols;
  EXPECT_GT(same, n / 50) << "at least 2% of the view in projector shadow";
  EXPECT_GT(brighter, n / 2) << "most of the view is lit by the projector";
}

// A point light lying on the wall, exactly where the centre pixel's ray
// hits it (distance 0): the light meets the wall at grazing incidence
// everywhere and adds nothing, not even at that point, where its direction
// is 0/0. The frame is the ambient-only frame, finite, and digitizes to it.
TEST(RenderTest, PointLightOnTheSurfaceAddsNothingAndStaysFinite) {
  const auto scene_json = [](const std::string& lights) {
    return absl::StrCat(
        R"({"name": "touching", "seed": 5,
            "camera": {"width": 161, "height": 121, "fx": 200, "fy": 200},
            "ambient_lux": 50,
            "objects": [{"name": "wall", "type": "plane",
                         "center_mm": [0, 0, 1000], "normal": [0, 0, -1]}])",
        lights, "}");
  };
  const Renderer touching(ParseOrDie(scene_json(
      R"(, "lights": [{"position_mm": [0, 0, 1000], "intensity_cd": 1000}])")));
  const Renderer ambient(ParseOrDie(scene_json("")));
  ASSERT_EQ(touching.scene().lights.size(), 1u);
  const View view = CameraView(touching.scene(), 0);
  const RadianceFrame frame = touching.Render(view, cv::Mat());
  ASSERT_EQ(frame.radiance.size(), cv::Size(161, 121));
  // The centre pixel (cx = 80, cy = 60) sees the light's own position.
  ASSERT_EQ(frame.object_id.at<uint16_t>(60, 80), 1);
  ASSERT_EQ(frame.depth.at<float>(60, 80), 1000.0f);

  cv::Point bad;
  EXPECT_TRUE(cv::checkRange(frame.radiance, /*quiet=*/true, &bad))
      << "non-finite radiance at x=" << bad.x << " y=" << bad.y;
  const cv::Mat expected = ambient.Render(view, cv::Mat()).radiance;
  EXPECT_EQ(cv::norm(frame.radiance, expected, cv::NORM_INF), 0.0);
  // Lambertian: albedo 0.5 x 50 lux / pi.
  EXPECT_NEAR(frame.radiance.at<cv::Vec3f>(60, 80)[1], 0.5 * 50 / M_PI, 1e-5);

  const ExposureSettings settings{1.0 / 125, 100};
  const cv::Mat image =
      RenderFrame(touching, view, cv::Mat(), settings, /*noise_seed=*/1, 8);
  const cv::Mat ambient_image =
      RenderFrame(ambient, view, cv::Mat(), settings, /*noise_seed=*/1, 8);
  EXPECT_EQ(cv::norm(image, ambient_image, cv::NORM_INF), 0.0);
  EXPECT_GT(image.at<cv::Vec3b>(60, 80)[1], 0) << "the ambient light shows";
}

// The checkerboard scene is usable for calibration: OpenCV finds its 9 x 6
// inner corners.
TEST(RenderTest, CheckerboardSceneHasNineBySixCorners) {
  ASSERT_OK_AND_ASSIGN(Scene scene, LoadBundledScene("checkerboard"));
  ScaleCamera(scene, scene.camera.width / 2);
  SimWorld world(scene);
  cv::Mat gray;
  cv::cvtColor(world.RenderExposure({1.0 / 125, 100}), gray,
               cv::COLOR_BGR2GRAY);
  std::vector<cv::Point2f> corners;
  EXPECT_TRUE(cv::findChessboardCorners(gray, cv::Size(9, 6), corners));
  EXPECT_EQ(corners.size(), 54u);
}

}  // namespace
}  // namespace hdrstereo::sim
