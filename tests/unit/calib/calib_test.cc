// SPDX-License-Identifier: GPL-3.0-or-later
//
// Stereo calibration and rectification on synthetic chessboard views
// rendered with a known camera: the board plane is mapped into each view by
// its exact homography K [r1 r2 t], rendered at 2x and area-downsampled.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "processing/calib/stereo_calibration.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::calib {
namespace {

using ::hdrstereo::testing::TempDir;

constexpr int kWidth = 400;
constexpr int kHeight = 300;
const cv::Size kCorners(7, 5);
constexpr double kSquare = 0.03;  // m
constexpr int kTexelsPerSquare = 40;

cv::Matx33d TrueK() {
  return cv::Matx33d(450, 0, 199.5, 0, 450, 149.5, 0, 0, 1);
}

// Board texture: (corners + 1) squares plus a one-square white margin.
cv::Mat BoardTexture() {
  const int sq = kTexelsPerSquare;
  const int cols = kCorners.width + 1, rows = kCorners.height + 1;
  cv::Mat t((rows + 2) * sq, (cols + 2) * sq, CV_8U, cv::Scalar(255));
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if ((r + c) % 2 == 0) {
        t(cv::Rect((c + 1) * sq, (r + 1) * sq, sq, sq)).setTo(20);
      }
    }
  }
  return t;
}

// Renders the board with pose (R, t) in the camera frame. Board point
// (X, Y, 0) in metres has its first inner corner at the origin.
cv::Mat Render(const cv::Matx33d& rot, const cv::Vec3d& t) {
  static const cv::Mat texture = BoardTexture();
  const double m_per_texel = kSquare / kTexelsPerSquare;
  // Texel (u, v) -> board metres: the first inner corner is at texel
  // (2 sq, 2 sq) (margin + one square); texel centres at +0.5.
  const cv::Matx33d texel_to_board(
      m_per_texel, 0, -(2 * kTexelsPerSquare - 0.5) * m_per_texel, 0,
      m_per_texel, -(2 * kTexelsPerSquare - 0.5) * m_per_texel, 0, 0, 1);
  // Render at 2x: x2 = 2x + 0.5.
  const cv::Matx33d k = TrueK();
  const cv::Matx33d k2(2 * k(0, 0), 0, 2 * k(0, 2) + 0.5, 0, 2 * k(1, 1),
                       2 * k(1, 2) + 0.5, 0, 0, 1);
  const cv::Matx33d rt(rot(0, 0), rot(0, 1), t[0], rot(1, 0), rot(1, 1), t[1],
                       rot(2, 0), rot(2, 1), t[2]);
  const cv::Matx33d h = k2 * rt * texel_to_board;
  cv::Mat big;
  cv::warpPerspective(texture, big, cv::Mat(h),
                      cv::Size(2 * kWidth, 2 * kHeight), cv::INTER_LINEAR,
                      cv::BORDER_CONSTANT, cv::Scalar(128));
  cv::Mat out;
  cv::resize(big, out, cv::Size(kWidth, kHeight), 0, 0, cv::INTER_AREA);
  return out;
}

cv::Matx33d Rotation(double rx, double ry, double rz) {
  cv::Matx33d r;
  cv::Rodrigues(cv::Vec3d(rx, ry, rz), r);
  return r;
}

struct Rig {
  cv::Matx33d rot;  // right = rot * left + trans
  cv::Vec3d trans;
};

struct Views {
  std::vector<cv::Mat> left, right;
  std::vector<std::string> left_names, right_names;
};

// Board poses in the left camera frame; the board centre sits ~0.6-0.75 m
// in front, tilted up to ~0.45 rad.
Views RenderViews(const Rig& rig) {
  const double tilts[][3] = {{0.0, 0.0, 0.0},    {0.35, 0.0, 0.05},
                             {-0.35, 0.1, 0.0},  {0.0, 0.4, -0.05},
                             {0.1, -0.4, 0.1},   {0.3, 0.3, 0.0},
                             {-0.3, -0.3, 0.05}, {0.2, -0.1, -0.1},
                             {-0.15, 0.45, 0.0}, {0.4, -0.2, 0.08}};
  Views v;
  int i = 0;
  for (const auto& tilt : tilts) {
    const cv::Matx33d r = Rotation(tilt[0], tilt[1], tilt[2]);
    // Put the board centre (3 x 2 squares from the first corner) in front,
    // between the two cameras.
    const cv::Vec3d centre_board(3 * kSquare, 2 * kSquare, 0);
    const cv::Vec3d where(0.02 * ((i % 3) - 1) + 0.04,
                          0.015 * ((i % 2) * 2 - 1), 0.62 + 0.015 * i);
    const cv::Vec3d t = where - r * centre_board;
    v.left.push_back(Render(r, t));
    v.right.push_back(Render(rig.rot * r, rig.rot * t + rig.trans));
    v.left_names.push_back("left_" + std::to_string(i) + ".png");
    v.right_names.push_back("right_" + std::to_string(i) + ".png");
    ++i;
  }
  return v;
}

CalibrationOptions Options() {
  CalibrationOptions o;
  o.board.inner_corners = kCorners;
  o.board.square_m = kSquare;
  return o;
}

TEST(CalibTest, MisalignedRigIsRectifiedToBelowAThirdPixelVerticalDisparity) {
  // Small rotation and a y offset on top of an 8 cm baseline.
  const Rig rig{Rotation(0.012, -0.02, 0.015), cv::Vec3d(-0.08, 0.004, 0.002)};
  Views v = RenderViews(rig);
  absl::StatusOr<StereoCalibration> c = CalibrateStereoFromImages(
      v.left, v.right, v.left_names, v.right_names, Options());
  ASSERT_TRUE(c.ok()) << c.status();
  // Against the truth, not itself.
  EXPECT_NEAR(c->camera_matrix.at<double>(0, 0), 450, 450 * 0.01);
  EXPECT_NEAR(c->camera_matrix.at<double>(0, 2), 199.5, 3);
  EXPECT_NEAR(cv::norm(c->translation), cv::norm(rig.trans),
              0.02 * cv::norm(rig.trans));
  EXPECT_LT(c->rms_stereo, 0.3);

  // Before: the rig really is misaligned.
  absl::StatusOr<std::vector<cv::Point2f>> l0 =
      FindChessboard(v.left[0], kCorners, "l0");
  absl::StatusOr<std::vector<cv::Point2f>> r0 =
      FindChessboard(v.right[0], kCorners, "r0");
  ASSERT_TRUE(l0.ok() && r0.ok());
  double before = 0;
  for (size_t k = 0; k < l0->size(); ++k) {
    before = std::max(before, double{std::abs((*l0)[k].y - (*r0)[k].y)});
  }
  EXPECT_GT(before, 3.0);

  // After: rectify the images and find the corners again.
  absl::StatusOr<RectificationMaps> maps = ComputeRectificationMaps(*c);
  ASSERT_TRUE(maps.ok()) << maps.status();
  double sum_sq = 0;
  int n = 0;
  for (size_t i = 0; i < v.left.size(); ++i) {
    absl::StatusOr<cv::Mat> l = Rectify(v.left[i], *maps, View::kLeft);
    absl::StatusOr<cv::Mat> r = Rectify(v.right[i], *maps, View::kRight);
    ASSERT_TRUE(l.ok() && r.ok());
    absl::StatusOr<std::vector<cv::Point2f>> lc =
        FindChessboard(*l, kCorners, "l");
    absl::StatusOr<std::vector<cv::Point2f>> rc =
        FindChessboard(*r, kCorners, "r");
    if (!lc.ok() || !rc.ok()) continue;  // board cut by the rectified border
    for (size_t k = 0; k < lc->size(); ++k) {
      const double dy = (*lc)[k].y - (*rc)[k].y;
      sum_sq += dy * dy;
      ++n;
    }
  }
  ASSERT_GE(n, 5 * kCorners.area());  // most views still usable
  const double rms = std::sqrt(sum_sq / n);
  EXPECT_LE(rms, 0.3) << "vertical disparity RMS (px) over " << n << " corners";
}

// Largest |map(x, y) - (x, y)| of both views over `roi`.
double MaxDisplacement(const RectificationMaps& maps, const cv::Rect& roi) {
  double worst = 0;
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      for (const auto& [mx, my] : {std::pair(&maps.left_x, &maps.left_y),
                                   std::pair(&maps.right_x, &maps.right_y)}) {
        worst = std::max({worst, double{std::abs(mx->at<float>(y, x) - x)},
                          double{std::abs(my->at<float>(y, x) - y)}});
      }
    }
  }
  return worst;
}

TEST(CalibTest, IdealRigGivesNearIdentityMaps) {
  const Rig rig{cv::Matx33d::eye(), cv::Vec3d(-0.08, 0, 0)};
  Views v = RenderViews(rig);
  absl::StatusOr<StereoCalibration> c = CalibrateStereoFromImages(
      v.left, v.right, v.left_names, v.right_names, Options());
  ASSERT_TRUE(c.ok()) << c.status();
  absl::StatusOr<RectificationMaps> maps = ComputeRectificationMaps(*c);
  ASSERT_TRUE(maps.ok()) << maps.status();
  // Where the boards constrain the lens model (the central part of the
  // image; distortion is extrapolated beyond it).
  const cv::Rect central(100, 75, 200, 150);
  EXPECT_LE(MaxDisplacement(*maps, central), 0.5) << "px";

  // With the lens model fixed distortion-free, the whole image.
  CalibrationOptions no_dist = Options();
  no_dist.zero_distortion = true;
  c = CalibrateStereoFromImages(v.left, v.right, v.left_names, v.right_names,
                                no_dist);
  ASSERT_TRUE(c.ok()) << c.status();
  maps = ComputeRectificationMaps(*c);
  ASSERT_TRUE(maps.ok()) << maps.status();
  EXPECT_LE(MaxDisplacement(*maps, cv::Rect(0, 0, kWidth, kHeight)), 0.5)
      << "px";
}

TEST(CalibTest, SaveAndLoadKeepTheRectification) {
  const Rig rig{Rotation(0.01, 0.0, 0.01), cv::Vec3d(-0.08, 0.003, 0)};
  Views v = RenderViews(rig);
  absl::StatusOr<StereoCalibration> c = CalibrateStereoFromImages(
      v.left, v.right, v.left_names, v.right_names, Options());
  ASSERT_TRUE(c.ok()) << c.status();
  TempDir dir;
  ASSERT_TRUE(SaveCalibration(dir / "rig.yml", *c).ok());
  absl::StatusOr<StereoCalibration> back = LoadCalibration(dir / "rig.yml");
  ASSERT_TRUE(back.ok()) << back.status();
  absl::StatusOr<RectificationMaps> a = ComputeRectificationMaps(*c);
  absl::StatusOr<RectificationMaps> b = ComputeRectificationMaps(*back);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_LE(cv::norm(a->right_x, b->right_x, cv::NORM_INF), 1e-3);
  EXPECT_LE(cv::norm(a->right_y, b->right_y, cv::NORM_INF), 1e-3);
  absl::StatusOr<std::vector<cv::Point2f>> p =
      RectifyPoints({cv::Point2f(100, 100)}, *back, View::kRight);
  ASSERT_TRUE(p.ok());
  // The point maps back through the remap table to where it came from.
  const cv::Point2f q = (*p)[0];
  const int qx = static_cast<int>(std::lround(q.x));
  const int qy = static_cast<int>(std::lround(q.y));
  EXPECT_NEAR(b->right_x.at<float>(qy, qx), 100, 1.0);
  EXPECT_NEAR(b->right_y.at<float>(qy, qx), 100, 1.0);
  std::ofstream(dir / "junk.yml") << "format: nope\n";
  absl::Status s = LoadCalibration(dir / "junk.yml").status();
  EXPECT_NE(s.message().find("junk.yml"), absl::string_view::npos) << s;
}

TEST(CalibTest, BoardNotFoundIsAnErrorNamingTheFile) {
  const Rig rig{cv::Matx33d::eye(), cv::Vec3d(-0.08, 0, 0)};
  Views v = RenderViews(rig);
  v.right[3] = cv::Mat(kHeight, kWidth, CV_8U, cv::Scalar(128));
  absl::Status s = CalibrateStereoFromImages(v.left, v.right, v.left_names,
                                             v.right_names, Options())
                       .status();
  EXPECT_EQ(s.code(), absl::StatusCode::kNotFound);
  EXPECT_NE(s.message().find("right_3.png"), absl::string_view::npos) << s;
  v.left.resize(2);
  v.right.resize(2);
  v.left_names.resize(2);
  v.right_names.resize(2);
  v.right[1] = v.left[1];
  EXPECT_FALSE(CalibrateStereoFromImages(v.left, v.right, v.left_names,
                                         v.right_names, Options())
                   .ok());  // fewer than 3 pairs
}

TEST(CalibTest, RectifyRejectsAWrongImageSize) {
  RectificationMaps maps;
  maps.image_size = cv::Size(10, 10);
  maps.left_x = maps.left_y = cv::Mat::zeros(10, 10, CV_32F);
  EXPECT_FALSE(Rectify(cv::Mat::zeros(5, 5, CV_8U), maps, View::kLeft).ok());
}

}  // namespace
}  // namespace hdrstereo::calib
