// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc mesopic end to end: the compensation for a dim display
// raises chroma (thesis 6.3.2: the inverse model counteracts mesopic
// desaturation), keeps the size, and bad input is a clear error.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/support/proc_tool.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::Proc;
using ::hdrstereo::testing::RunCommand;
using ::hdrstereo::testing::TempDir;

double MeanChroma(const cv::Mat& bgr) {
  cv::Mat lab;
  bgr.convertTo(lab, CV_32F, 1 / 255.0);
  cv::cvtColor(lab, lab, cv::COLOR_BGR2Lab);
  std::vector<cv::Mat> channels;
  cv::split(lab, channels);
  cv::Mat chroma;
  cv::magnitude(channels[1], channels[2], chroma);
  return cv::mean(chroma)[0];
}

TEST(MesopicToolTest, CompensationRaisesChromaAndKeepsSize) {
  TempDir dir;
  // Muted colour patches on a mid-grey background.
  cv::Mat image(60, 90, CV_8UC3, cv::Scalar(128, 128, 128));
  image(cv::Rect(0, 0, 30, 60)).setTo(cv::Scalar(60, 80, 170));   // red-ish
  image(cv::Rect(30, 0, 30, 60)).setTo(cv::Scalar(70, 160, 80));  // green
  image(cv::Rect(60, 0, 30, 60)).setTo(cv::Scalar(170, 90, 60));  // blue
  ASSERT_TRUE(cv::imwrite((dir / "in.png").string(), image));
  CommandResult r = Proc({"mesopic", "--in", (dir / "in.png").string(), "--out",
                          (dir / "out.png").string(), "--display-cd", "2",
                          "--method", "shin", "--no-tone-curve"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  cv::Mat out = cv::imread((dir / "out.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(out.size(), image.size());
  ASSERT_EQ(out.type(), CV_8UC3);
  EXPECT_GT(MeanChroma(out), 1.05 * MeanChroma(image));
}

TEST(MesopicToolTest, BadMethodAndMissingFileAreErrors) {
  TempDir dir;
  ASSERT_TRUE(cv::imwrite((dir / "in.png").string(),
                          cv::Mat(8, 8, CV_8UC3, cv::Scalar(90, 100, 110))));
  CommandResult bad =
      Proc({"mesopic", "--in", (dir / "in.png").string(), "--out",
            (dir / "o.png").string(), "--method", "magic"});
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("magic"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "o.png"));
  CommandResult missing = Proc({"mesopic", "--in", (dir / "nope.png").string(),
                                "--out", (dir / "o.png").string()});
  EXPECT_NE(missing.exit_code, 0);
}

}  // namespace
}  // namespace hdrstereo
