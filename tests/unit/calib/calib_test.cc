// SPDX-License-Identifier: GPL-3.0-or-later
//
// Stereo calibration and rectification on synthetic chessboard views
// rendered with a known camera (tests/unit/calib/synthetic_rig.h).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "processing/calib/stereo_calibration.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/calib/synthetic_rig.h"

namespace hdrstereo::calib {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using ::hdrstereo::testing::TempDir;

using ::hdrstereo::testing::kCorners;
using ::hdrstereo::testing::kHeight;
using ::hdrstereo::testing::kSquare;
using ::hdrstereo::testing::kWidth;
using ::hdrstereo::testing::RenderViews;
using ::hdrstereo::testing::Rig;
using ::hdrstereo::testing::Rotation;
using ::hdrstereo::testing::Views;

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

TEST(CalibTest, AssessmentGivesPerPoseErrorsAndCoverage) {
  const Rig rig{Rotation(0.012, -0.02, 0.015), cv::Vec3d(-0.08, 0.004, 0.002)};
  Views v = RenderViews(rig);
  std::vector<std::vector<cv::Point2f>> left, right;
  for (size_t i = 0; i < v.left.size(); ++i) {
    absl::StatusOr<std::vector<cv::Point2f>> l =
        FindChessboard(v.left[i], kCorners, v.left_names[i]);
    absl::StatusOr<std::vector<cv::Point2f>> r =
        FindChessboard(v.right[i], kCorners, v.right_names[i]);
    ASSERT_TRUE(l.ok() && r.ok());
    left.push_back(*l);
    right.push_back(*r);
  }
  absl::StatusOr<StereoCalibration> c =
      CalibrateStereo(left, right, v.left[0].size(), Options());
  ASSERT_TRUE(c.ok()) << c.status();
  absl::StatusOr<CalibrationQuality> q =
      AssessCalibration(*c, left, right, Options().board);
  ASSERT_TRUE(q.ok()) << q.status();
  ASSERT_EQ(q->rms_left.size(), left.size());
  ASSERT_EQ(q->rms_right.size(), right.size());
  for (size_t i = 0; i < left.size(); ++i) {
    EXPECT_LT(q->rms_left[i], 0.5) << "pose " << i;
    EXPECT_LT(q->rms_right[i], 0.5) << "pose " << i;
  }
  EXPECT_GT(q->coverage_fraction_left, 0.05);
  EXPECT_LE(q->coverage_fraction_left, 1.0);
  EXPECT_EQ(q->coverage_left.size(), v.left[0].size());
  // The fraction is the mask's.
  EXPECT_NEAR(q->coverage_fraction_left,
              cv::countNonZero(q->coverage_left) /
                  static_cast<double>(q->coverage_left.total()),
              1e-12);
  // One pose covers less than all of them together.
  const cv::Mat one = CoverageMask({left[0]}, v.left[0].size());
  EXPECT_LT(cv::countNonZero(one), cv::countNonZero(q->coverage_left));
  EXPECT_THAT(AssessCalibration(*c, left, {}, Options().board).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("as many left as right poses")));
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
  EXPECT_THAT(
      Rectify(cv::Mat::zeros(5, 5, CV_8U), maps, View::kLeft),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("image is 5x5 but the rig was calibrated at 10x10")));
}

}  // namespace
}  // namespace hdrstereo::calib
