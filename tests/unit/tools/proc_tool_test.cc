// SPDX-License-Identifier: GPL-3.0-or-later
//
// The hdrstereo-proc executable end to end on synthetic data with known
// truth: response + merge of a rendered exposure stack, calibrate + rectify
// of rendered chessboard pairs, and its errors on bad input.
#include "tests/support/proc_tool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "processing/calib/stereo_calibration.h"
#include "processing/hdr/response.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/calib/synthetic_rig.h"
#include "tests/unit/hdr/synthetic_scene.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::Proc;
using ::hdrstereo::testing::RunCommand;
using ::hdrstereo::testing::TempDir;

void WriteStack(const std::filesystem::path& dir, cv::Mat& radiance) {
  std::filesystem::create_directories(dir);
  radiance = testing::SyntheticRadiance(96, 72);
  const std::vector<double> times = testing::ThesisExposureTimes();
  std::vector<cv::Mat> images = testing::RenderExposures(
      radiance, times, testing::TrueResponse{}, 0.005, 7);
  std::ofstream list(dir / "exposures.txt");
  for (size_t j = 0; j < images.size(); ++j) {
    const std::string name = "exp" + std::to_string(j) + ".png";
    ASSERT_TRUE(cv::imwrite((dir / name).string(), images[j]));
    list << name << " 1/" << std::lround(1 / times[j]) << "\n";
  }
}

TEST(ProcToolTest, ResponseAndMergeOfARenderedStack) {
  TempDir dir;
  cv::Mat truth;
  WriteStack(dir / "stack", truth);
  CommandResult r = Proc({"response", "--stack", (dir / "stack").string(),
                          "--out", (dir / "resp.yml").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  absl::StatusOr<hdr::CameraResponse> resp =
      hdr::LoadResponse(dir / "resp.yml");
  ASSERT_TRUE(resp.ok()) << resp.status();

  r = Proc({"merge", "--stack", (dir / "stack").string(), "--response",
            (dir / "resp.yml").string(), "--out", (dir / "rad.exr").string(),
            "--float", "--hdr", (dir / "rad.hdr").string(), "--log-luminance",
            (dir / "logl.pfm").string(), "--mask",
            (dir / "mask.png").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("9 pixels saturated"), std::string::npos) << r.out;
  absl::StatusOr<cv::Mat> rad = io::ReadExr(dir / "rad.exr");
  ASSERT_TRUE(rad.ok()) << rad.status();
  absl::StatusOr<cv::Mat> mask =
      io::DecodeImageFile(dir / "mask.png").value_or(io::DecodedImage{}).pixels;
  ASSERT_EQ(mask->size(), truth.size());
  // Green channel against the truth after fitting the free scale: median
  // relative error <= 2% over unflagged pixels.
  std::vector<double> ratio;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      if (mask->at<uint8_t>(y, x)) continue;
      ratio.push_back(rad->at<cv::Vec3f>(y, x)[1] /
                      truth.at<cv::Vec3f>(y, x)[1]);
    }
  }
  std::vector<double> sorted = ratio;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2,
                   sorted.end());
  const double scale = sorted[sorted.size() / 2];
  std::vector<double> err;
  for (double q : ratio) err.push_back(std::abs(q / scale - 1));
  std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
  EXPECT_LE(err[err.size() / 2], 0.02);
  absl::StatusOr<cv::Mat> logl = io::ReadPfm(dir / "logl.pfm");
  ASSERT_TRUE(logl.ok()) << logl.status();
  EXPECT_EQ(logl->channels(), 1);
  EXPECT_TRUE(io::ReadRgbe(dir / "rad.hdr").ok());
}

TEST(ProcToolTest, BadStacksFailWithTheFileNamed) {
  TempDir dir;
  std::filesystem::create_directories(dir / "one");
  cv::Mat img(8, 8, CV_8UC3, cv::Scalar::all(90));
  ASSERT_TRUE(cv::imwrite((dir / "one/a.png").string(), img));
  std::ofstream(dir / "one/exposures.txt") << "a.png 1/60\n";
  CommandResult r = Proc({"merge", "--stack", (dir / "one").string(), "--out",
                          (dir / "x.exr").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("at least 2 exposures"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.exr"));

  ASSERT_TRUE(cv::imwrite((dir / "one/b.png").string(),
                          cv::Mat(8, 9, CV_8UC3, cv::Scalar::all(1))));
  std::ofstream(dir / "one/exposures.txt") << "a.png 1/60\nb.png 1/30\n";
  r = Proc({"response", "--stack", (dir / "one").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("b.png"), std::string::npos) << r.err;

  r = Proc({"merge", "--stack", (dir / "none").string(), "--out", "y.exr"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("none"), std::string::npos) << r.err;
}

TEST(ProcToolTest, CalibrateThenRectifyAStackFolder) {
  TempDir dir;
  const testing::Rig rig{testing::Rotation(0.01, -0.015, 0.01),
                         cv::Vec3d(-0.08, 0.004, 0)};
  testing::Views v = testing::RenderViews(rig);
  std::filesystem::create_directories(dir / "cal/left");
  std::filesystem::create_directories(dir / "cal/right");
  for (size_t i = 0; i < v.left.size(); ++i) {
    ASSERT_TRUE(
        cv::imwrite((dir / "cal/left" / v.left_names[i]).string(), v.left[i]));
    ASSERT_TRUE(cv::imwrite((dir / "cal/right" / v.right_names[i]).string(),
                            v.right[i]));
  }
  CommandResult r = Proc({"calibrate", "--captures", (dir / "cal").string(),
                          "--board", "7x5", "--square", "0.03"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(std::filesystem::exists(dir / "cal/rig.yml"));

  // Rectify the right view's "stack" (two images + exposures.txt).
  std::filesystem::create_directories(dir / "right_stack");
  ASSERT_TRUE(cv::imwrite((dir / "right_stack/a.png").string(), v.right[0]));
  ASSERT_TRUE(cv::imwrite((dir / "right_stack/b.png").string(), v.right[1]));
  std::ofstream(dir / "right_stack/exposures.txt")
      << "a.png 1/60\nb.png 1/30\n";
  r = Proc({"rectify", "--rig", (dir / "cal/rig.yml").string(), "--view",
            "right", "--out-dir", (dir / "rect").string(),
            (dir / "right_stack").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "rect/exposures.txt"));
  // The rectified right board lines up with the rectified left board.
  absl::StatusOr<calib::StereoCalibration> c =
      calib::LoadCalibration(dir / "cal/rig.yml");
  ASSERT_TRUE(c.ok());
  absl::StatusOr<calib::RectificationMaps> maps =
      calib::ComputeRectificationMaps(*c);
  ASSERT_TRUE(maps.ok());
  absl::StatusOr<cv::Mat> left =
      calib::Rectify(v.left[0], *maps, calib::View::kLeft);
  cv::Mat right =
      cv::imread((dir / "rect/a.png").string(), cv::IMREAD_GRAYSCALE);
  auto lc = calib::FindChessboard(*left, testing::kCorners, "left");
  auto rc = calib::FindChessboard(right, testing::kCorners, "right");
  ASSERT_TRUE(lc.ok() && rc.ok());
  double sum_sq = 0;
  for (size_t k = 0; k < lc->size(); ++k) {
    sum_sq += std::pow((*lc)[k].y - (*rc)[k].y, 2);
  }
  EXPECT_LE(std::sqrt(sum_sq / lc->size()), 0.3);

  // A pair without a board names the file.
  cv::Mat blank(testing::kHeight, testing::kWidth, CV_8U, cv::Scalar(128));
  ASSERT_TRUE(
      cv::imwrite((dir / "cal/right" / v.right_names[4]).string(), blank));
  r = Proc(
      {"calibrate", "--captures", (dir / "cal").string(), "--board", "7x5"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(v.right_names[4]), std::string::npos) << r.err;
  r = Proc({"rectify", "--rig", (dir / "cal/rig.yml").string(), "--view", "up",
            "--out-dir", (dir / "r2").string(),
            (dir / "right_stack").string()});
  EXPECT_EQ(r.exit_code, 1);
}

}  // namespace
}  // namespace hdrstereo
