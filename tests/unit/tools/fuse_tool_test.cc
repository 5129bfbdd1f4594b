// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc fuse end to end: seven candidate PFMs (one corrupted) and a
// PNG guide; alpha-expansion recovers the truth, mean/median write their
// baselines, bad input is refused with a message.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "processing/io/hdr_formats.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::RunCommand;
using ::hdrstereo::testing::TempDir;

CommandResult Proc(std::vector<std::string> args) {
  args.insert(args.begin(), HDRSTEREO_PROC);
  absl::StatusOr<CommandResult> r = RunCommand(args, absl::Seconds(300));
  EXPECT_TRUE(r.ok()) << r.status();
  return r.ok() ? *r : CommandResult{};
}

cv::Mat Truth() {
  cv::Mat d(24, 40, CV_32FC1);
  for (int y = 0; y < d.rows; ++y) {
    for (int x = 0; x < d.cols; ++x) d.at<float>(y, x) = x < 20 ? 5.0f : 12.0f;
  }
  return d;
}

void WriteInputs(const TempDir& dir) {
  std::filesystem::create_directories(dir / "cands");
  for (int k = 0; k < 7; ++k) {
    cv::Mat c =
        k == 2 ? cv::Mat(Truth().size(), CV_32FC1, cv::Scalar(17.0f)) : Truth();
    ASSERT_TRUE(
        io::WritePfm(dir / "cands" / ("c" + std::to_string(k) + ".pfm"), c)
            .ok());
  }
  cv::Mat guide(24, 40, CV_8UC1);
  for (int x = 0; x < 40; ++x) guide.col(x).setTo(x < 20 ? 50 : 200);
  ASSERT_TRUE(cv::imwrite((dir / "left.png").string(), guide));
}

TEST(FuseToolTest, AlphaMeanMedian) {
  TempDir dir;
  WriteInputs(dir);
  for (const std::string method : {"alpha", "mean", "median"}) {
    const std::string out = (dir / (method + ".pfm")).string();
    CommandResult r =
        Proc({"fuse", "--candidates", (dir / "cands").string(), "--guide",
              (dir / "left.png").string(), "--max-disp", "20", "--out", out,
              "--method", method});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    absl::StatusOr<cv::Mat> fused = io::ReadPfm(out);
    ASSERT_TRUE(fused.ok()) << fused.status();
    const double err = cv::norm(*fused, Truth(), cv::NORM_INF);
    if (method == "mean") {
      EXPECT_GT(err, 1.0);  // pulled by the corrupted candidate
    } else {
      EXPECT_EQ(err, 0.0) << method;
    }
    if (method == "alpha") {
      EXPECT_NE(r.out.find("energy"), std::string::npos) << r.out;
    }
  }
}

TEST(FuseToolTest, BadInputIsAnError) {
  TempDir dir;
  WriteInputs(dir);
  CommandResult r =
      Proc({"fuse", "--candidates", (dir / "cands").string(), "--guide",
            (dir / "left.png").string(), "--max-disp", "20", "--out",
            (dir / "x.pfm").string(), "--method", "vote"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("vote"), std::string::npos) << r.err;
  std::filesystem::create_directories(dir / "empty");
  r = Proc({"fuse", "--candidates", (dir / "empty").string(), "--guide",
            (dir / "left.png").string(), "--max-disp", "20", "--out",
            (dir / "x.pfm").string()});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("no .pfm"), std::string::npos) << r.err;
  r = Proc({"fuse", "--candidates", (dir / "cands").string(), "--max-disp",
            "20", "--out", (dir / "x.pfm").string()});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--guide"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace hdrstereo
