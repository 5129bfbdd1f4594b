// SPDX-License-Identifier: GPL-3.0-or-later
//
// The hdrstereo-sim tool end to end: render a frame and the truth of a small
// slanted-plane scene, read the files back and check them against geometry.
#include <gtest/gtest.h>
#include <signal.h>

#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "absl/time/clock.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/sim/test_scenes.h"

namespace hdrstereo::sim {
namespace {

using ::hdrstereo::sim::testing::kCx;
using ::hdrstereo::sim::testing::kCy;
using ::hdrstereo::sim::testing::kF;

TEST(ToolTest, RendersFrameAndTruthFiles) {
  hdrstereo::testing::TempDir dir;
  const std::filesystem::path scene_path = dir / "slant.json";
  {
    std::ofstream out(scene_path);
    out << testing::SmallSceneJson(
        R"({"type": "plane", "center_mm": [0, 0, 1000],
            "normal": [0, -0.2, 1]})");
  }
  absl::StatusOr<hdrstereo::testing::CommandResult> r =
      hdrstereo::testing::RunCommand(
          {HDRSTEREO_SIM_TOOL, "render", "--scene", scene_path.string(),
           "--stage-mm", "10", "--exposure-s", "0.01", "--truth",
           "--baseline-mm", "100", "--out", (dir / "out").string()});
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->exit_code, 0) << r->err;

  const cv::Mat frame =
      cv::imread((dir / "out/frame.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(frame.size(), cv::Size(160, 120));
  EXPECT_EQ(frame.type(), CV_8UC3);
  // Z = 1000 + 0.2 Y  =>  d = f B / 1000 * (1 - 0.2 (v - cy) / f); the
  // top rows are nearer, so a flipped PFM would fail.
  const cv::Mat disp =
      cv::imread((dir / "out/disp0.pfm").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(disp.type(), CV_32FC1);
  ASSERT_EQ(disp.size(), cv::Size(160, 120));
  for (int y = 0; y < 120; y += 10) {
    const double expected = kF * 100 / 1000 * (1 - 0.2 * (y - kCy) / kF);
    EXPECT_NEAR(disp.at<float>(y, 17), expected, 1e-3) << "row " << y;
  }
  for (const char* name :
       {"disp1.pfm", "depth0.pfm", "depth1.pfm", "radiance0.pfm",
        "radiance1.pfm", "nonocc0.png", "nonocc1.png", "calib.txt"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / name)) << name;
  }
  std::ifstream calib(dir / "out/calib.txt");
  std::string text((std::istreambuf_iterator<char>(calib)), {});
  EXPECT_NE(text.find("\nbaseline=100\n"), std::string::npos) << text;
}

TEST(ToolTest, BadSceneIsAUsageErrorNamingTheField) {
  hdrstereo::testing::TempDir dir;
  const std::filesystem::path scene_path = dir / "bad.json";
  {
    std::ofstream out(scene_path);
    out << testing::SmallSceneJson(R"({"type": "sphere",
                                       "center_mm": [0, 0, 1000]})");
  }
  absl::StatusOr<hdrstereo::testing::CommandResult> r =
      hdrstereo::testing::RunCommand({HDRSTEREO_SIM_TOOL, "render", "--scene",
                                      scene_path.string(), "--out",
                                      (dir / "out").string()});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->exit_code, 2);
  EXPECT_NE(r->err.find("objects[0].radius_mm"), std::string::npos) << r->err;
}

// `hdrstereo-sim camera --ptpip` serves the simulated camera on its own:
// it prints libgphoto2's port string, Debian's gphoto2 client reads the
// camera there, and SIGTERM ends it.
TEST(ToolTest, ServesAPtpIpCameraThatGphoto2Reads) {
  hdrstereo::testing::TempDir dir;
  const std::filesystem::path log = dir / "camera.log";
  absl::StatusOr<hdrstereo::testing::Process> camera =
      hdrstereo::testing::Process::Start(
          {HDRSTEREO_SIM_TOOL, "camera", "--ptpip", "127.0.0.1:0", "--scene",
           "textured"},
          log);
  ASSERT_TRUE(camera.ok()) << camera.status();
  ASSERT_TRUE(hdrstereo::testing::WaitForFile(log, absl::Seconds(30)));
  std::string port;
  for (int i = 0; i < 100 && port.find('\n') == std::string::npos; ++i) {
    std::ifstream in(log);
    std::getline(in, port, '\0');
    absl::SleepFor(absl::Milliseconds(50));
  }
  port = port.substr(0, port.find('\n'));
  ASSERT_EQ(port.rfind("ptpip:127.0.0.1:", 0), 0u) << port;
  absl::StatusOr<hdrstereo::testing::CommandResult> summary =
      hdrstereo::testing::RunCommand({"/usr/bin/gphoto2", "--port", port,
                                      "--camera", "PTP/IP Camera",
                                      "--summary"});
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->exit_code, 0) << summary->err;
  EXPECT_NE(summary->out.find("Model: hdrstereo simulated camera (textured)"),
            std::string::npos)
      << summary->out;
  camera->Signal(SIGTERM);
  EXPECT_EQ(camera->Wait(absl::Seconds(10)), 0);
}

TEST(ToolTest, APtpIpAddressThatIsNotOneIsAUsageError) {
  absl::StatusOr<hdrstereo::testing::CommandResult> r =
      hdrstereo::testing::RunCommand(
          {HDRSTEREO_SIM_TOOL, "camera", "--ptpip", "camera.lab:15740"});
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->exit_code, 2);
  EXPECT_NE(r->err.find("\"camera.lab\" is not an IPv4 address"),
            std::string::npos)
      << r->err;
}

}  // namespace
}  // namespace hdrstereo::sim
