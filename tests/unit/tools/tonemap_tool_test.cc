// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc tonemap end to end: every operator writes an 8-bit image
// that spans the display range, a pair of identical views maps identically
// (shared normalisation), and a bad operator name is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "processing/io/hdr_formats.h"
#include "processing/tonemap/tonemap.h"
#include "tests/support/proc_tool.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::Proc;
using ::hdrstereo::testing::RunCommand;
using ::hdrstereo::testing::TempDir;

// A horizontal log ramp from 1 to 8000 cd/m^2 with a coloured band.
cv::Mat Ramp() {
  cv::Mat radiance(48, 96, CV_32FC3);
  for (int y = 0; y < radiance.rows; ++y) {
    for (int x = 0; x < radiance.cols; ++x) {
      const float l = std::pow(8000.0f, x / float(radiance.cols - 1));
      radiance.at<cv::Vec3f>(y, x) =
          y < 16 ? cv::Vec3f(0.3f * l, 0.5f * l, l) : cv::Vec3f(l, l, l);
    }
  }
  return radiance;
}

TEST(TonemapToolTest, EveryOperatorOnAPair) {
  TempDir dir;
  ASSERT_TRUE(
      io::WriteExr(dir / "l.exr", Ramp(), io::ExrPixelType::kFloat).ok());
  CommandResult r = Proc(
      {"tonemap", "--op", "all", "--in", (dir / "l.exr").string(), "--right",
       (dir / "l.exr").string(), "--out", (dir / "out").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (tonemap::Operator op : tonemap::AllOperators()) {
    const std::string name = tonemap::OperatorName(op);
    cv::Mat left = cv::imread((dir / "out" / (name + "_left.png")).string(),
                              cv::IMREAD_UNCHANGED);
    cv::Mat right = cv::imread((dir / "out" / (name + "_right.png")).string(),
                               cv::IMREAD_UNCHANGED);
    ASSERT_EQ(left.type(), CV_8UC3) << name;
    ASSERT_EQ(left.size(), cv::Size(96, 48)) << name;
    EXPECT_EQ(cv::norm(left, right, cv::NORM_INF), 0) << name;
    double lo = 0, hi = 0;
    cv::minMaxLoc(left.reshape(1), &lo, &hi);
    EXPECT_LT(lo, 64) << name;
    EXPECT_GT(hi, 200) << name;
  }
}

TEST(TonemapToolTest, UnknownOperatorIsAnError) {
  TempDir dir;
  ASSERT_TRUE(
      io::WriteExr(dir / "l.exr", Ramp(), io::ExrPixelType::kFloat).ok());
  CommandResult r =
      Proc({"tonemap", "--op", "mantiuk", "--in", (dir / "l.exr").string(),
            "--out", (dir / "out").string()});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("mantiuk"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace hdrstereo
