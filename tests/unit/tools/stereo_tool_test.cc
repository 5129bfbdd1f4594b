// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc stereo and eval end to end on a rendered pair with exact
// truth, and their errors on bad input.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hardware/sim/truth.h"
#include "processing/io/hdr_formats.h"
#include "tests/support/proc_tool.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::Proc;
using ::hdrstereo::testing::RunCommand;
using ::hdrstereo::testing::TempDir;

// Renders a 160x120 `textured` pair (baseline 100 mm) with truth into dir.
void WritePair(const TempDir& dir) {
  absl::StatusOr<sim::Scene> scene = sim::LoadScene("textured");
  ASSERT_TRUE(scene.ok());
  const double k = 160.0 / scene->camera.width;
  scene->camera = {160,  120, scene->camera.fx * k, scene->camera.fy * k,
                   79.5, 59.5};
  sim::SimWorld world(*scene);
  world.SetStagePosition(0);
  ASSERT_TRUE(cv::imwrite((dir / "left.png").string(),
                          world.RenderExposure({1.0 / 20, 100}, 8)));
  world.SetStagePosition(100);
  ASSERT_TRUE(cv::imwrite((dir / "right.png").string(),
                          world.RenderExposure({1.0 / 20, 100}, 8)));
  absl::StatusOr<sim::StereoTruth> truth = world.Truth(0, 100);
  ASSERT_TRUE(truth.ok());
  ASSERT_TRUE(io::WritePfm(dir / "gt.pfm", truth->left.disparity).ok());
  ASSERT_TRUE(
      cv::imwrite((dir / "nonocc.png").string(), truth->left.nonoccluded));
}

TEST(StereoToolTest, StereoThenEval) {
  TempDir dir;
  WritePair(dir);
  CommandResult r =
      Proc({"stereo", "--left", (dir / "left.png").string(), "--right",
            (dir / "right.png").string(), "--min-disp", "0", "--max-disp", "20",
            "--out", (dir / "disp.pfm").string(), "--png",
            (dir / "disp.png").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "disp.png"));
  r = Proc({"eval", "--disp", (dir / "disp.pfm").string(), "--gt",
            (dir / "gt.pfm").string(), "--nonocc",
            (dir / "nonocc.png").string(), "--json", "--error-png",
            (dir / "err.png").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"nonoccluded\": {"), std::string::npos) << r.out;
  EXPECT_TRUE(std::filesystem::exists(dir / "err.png"));
  r = Proc({"eval", "--disp", (dir / "disp.pfm").string(), "--gt",
            (dir / "gt.pfm").string(), "--mask",
            (dir / "nonocc.png").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("rmse"), std::string::npos) << r.out;
}

TEST(StereoToolTest, BadInputFailsClearly) {
  TempDir dir;
  WritePair(dir);
  const std::string l = (dir / "left.png").string();
  CommandResult r =
      Proc({"stereo", "--left", l, "--right", l, "--min-disp", "5",
            "--max-disp", "5", "--out", (dir / "d.pfm").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("must be greater"), std::string::npos) << r.err;
  r = Proc({"stereo", "--left", l, "--right", l, "--max-disp", "500", "--out",
            (dir / "d.pfm").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("wider than the image"), std::string::npos) << r.err;
  cv::Mat small(10, 10, CV_8UC3, cv::Scalar::all(7));
  ASSERT_TRUE(cv::imwrite((dir / "small.png").string(), small));
  r = Proc({"stereo", "--left", l, "--right", (dir / "small.png").string(),
            "--max-disp", "4", "--out", (dir / "d.pfm").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("differ in size"), std::string::npos) << r.err;
  r = Proc({"stereo", "--left", l, "--right", l, "--max-disp", "4", "--hdr",
            "--out", (dir / "d.pfm").string()});
  EXPECT_EQ(r.exit_code, 0) << r.err;  // 8-bit taken as linear radiance
  r = Proc({"eval", "--disp", (dir / "gt.pfm").string(), "--gt",
            (dir / "small.png").string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("one channel"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace hdrstereo
