// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc sl decode / sl disparity on a simulated capture written in
// the capture-job layout, and clear errors for broken captures.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "processing/io/capture_layout.h"
#include "processing/io/hdr_formats.h"
#include "processing/structured_light/decode.h"
#include "tests/support/proc_tool.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/structured_light/sim_capture.h"

namespace hdrstereo::structured_light {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::Proc;
using ::hdrstereo::testing::RunCommand;
using ::hdrstereo::testing::TempDir;

// Writes a small shadowed-scene capture (160 x 120, one exposure) as
// captures/<id>/<view>/structured_light/sl_<pattern>_exp_1-30s.png.
std::filesystem::path WriteCapture(const std::filesystem::path& root,
                                   testing::SimCapture* capture_out) {
  *capture_out = testing::RenderSimCapture("shadowed", {1.0 / 30}, 160);
  for (int v = 0; v < 2; ++v) {
    std::filesystem::create_directories(
        root /
        io::RoleDir(1, io::ViewName(v), io::FrameRole::kStructuredLight));
    const std::vector<Pattern> patterns =
        AllPatterns(capture_out->views[v].projector_size);
    for (size_t i = 0; i < patterns.size(); ++i) {
      io::FrameKey key;
      key.role = io::FrameRole::kStructuredLight;
      key.exposure_s = 1.0 / 30;
      key.pattern = patterns[i].Id();
      key.inverse = patterns[i].inverse;
      EXPECT_TRUE(cv::imwrite(
          (root / (io::FrameStem(1, io::ViewName(v), key) + ".png")).string(),
          capture_out->views[v].exposures[0].frames[i]));
    }
  }
  return root / io::CaptureDir(1);
}

TEST(SlToolTest, DecodeAndDisparityWriteTheirFiles) {
  TempDir tmp;
  testing::SimCapture capture;
  const std::filesystem::path dir = WriteCapture(tmp.path(), &capture);
  const std::filesystem::path out = tmp.path() / "out";

  CommandResult r = Proc({"sl", "decode", "--capture", dir.string(), "--out",
                          out.string(), "--projector", "1024x768"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_TRUE(std::filesystem::exists(out / "left_column.png"));
  EXPECT_TRUE(std::filesystem::exists(out / "right_row.png"));
  cv::Mat col =
      cv::imread((out / "left_column.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(col.type(), CV_16UC1);
  const testing::SimViewTruth& t = capture.truth[0];
  int checked = 0, equal = 0;
  for (int y = 0; y < col.rows; ++y) {
    for (int x = 0; x < col.cols; ++x) {
      if (col.at<uint16_t>(y, x) == 65535 || !t.lit.at<uint8_t>(y, x)) continue;
      ++checked;
      equal += col.at<uint16_t>(y, x) == t.column.at<int32_t>(y, x);
    }
  }
  EXPECT_GT(checked, col.total() / 2);
  EXPECT_GE(equal, 0.995 * checked);

  r = Proc(
      {"sl", "disparity", "--capture", dir.string(), "--out", out.string()});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("\"coverage_of_lit\""), std::string::npos) << r.out;
  absl::StatusOr<cv::Mat> disp0 = io::ReadPfm(out / "disp0GT.pfm");
  ASSERT_TRUE(disp0.ok()) << disp0.status();
  int valid = 0, good = 0;
  for (int y = 0; y < disp0->rows; ++y) {
    for (int x = 0; x < disp0->cols; ++x) {
      const float d = disp0->at<float>(y, x);
      const float truth = t.disparity.at<float>(y, x);
      if (!std::isfinite(d) || !std::isfinite(truth)) continue;
      ++valid;
      good += std::abs(d - truth) <= 0.5;
    }
  }
  EXPECT_GT(valid, disp0->total() / 2);
  EXPECT_GE(good, 0.99 * valid);
  EXPECT_TRUE(std::filesystem::exists(out / "disp1GT.pfm"));
  EXPECT_TRUE(std::filesystem::exists(out / "mask0nocc.png"));
}

TEST(SlToolTest, BrokenCapturesAreClearErrors) {
  TempDir tmp;
  testing::SimCapture capture;
  const std::filesystem::path dir = WriteCapture(tmp.path(), &capture);
  const std::filesystem::path out = tmp.path() / "out";
  std::filesystem::remove(dir / "right" / "structured_light" /
                          "sl_row_b04_inv_exp_1-30s.png");
  CommandResult r = Proc(
      {"sl", "disparity", "--capture", dir.string(), "--out", out.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("sl_row_b04_inv_exp_1-30s is missing"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(out / "disp0GT.pfm"));

  r = Proc({"sl", "decode", "--capture", dir.string(), "--out", out.string(),
            "--projector", "2048x768"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("needs 11 and 10"), std::string::npos) << r.err;

  r = Proc({"sl", "decode", "--capture", tmp.path().string(), "--out",
            out.string()});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no structured-light folder"), std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace hdrstereo::structured_light
