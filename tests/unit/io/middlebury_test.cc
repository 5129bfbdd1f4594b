// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Middlebury format: calib.txt written and read back, a file in the
// form the 2014 data sets publish (with their extra keys), errors naming
// the key, the ground-truth files and the mask from a truth.
#include "processing/io/middlebury.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"
#include "processing/io/atomic_file.h"
#include "processing/io/hdr_formats.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::io {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::TempDir;
using ::testing::HasSubstr;

constexpr float kInf = std::numeric_limits<float>::infinity();

Calib Sample() {
  Calib c;
  c.fx = 800.5;
  c.fy = 801.25;
  c.cx = 319.5;
  c.cy = 239.5;
  c.baseline_mm = 150;
  c.width = 640;
  c.height = 480;
  c.ndisp = 64;
  c.extra = {{"left_stage_mm", "0.000000"}};
  return c;
}

TEST(MiddleburyTest, CalibTextIsTheStandardKeysInOrder) {
  EXPECT_EQ(FormatCalib(Sample()),
            "cam0=[800.5 0 319.5; 0 801.25 239.5; 0 0 1]\n"
            "cam1=[800.5 0 319.5; 0 801.25 239.5; 0 0 1]\n"
            "doffs=0\nbaseline=150\nwidth=640\nheight=480\nndisp=64\n"
            "left_stage_mm=0.000000\n");
}

TEST(MiddleburyTest, CalibRoundTripsThroughAFile) {
  TempDir tmp;
  const Calib c = Sample();
  ASSERT_OK(WriteCalib(tmp / kCalibFile, c));
  ASSERT_OK_AND_ASSIGN(const Calib back, ReadCalib(tmp / kCalibFile));
  EXPECT_DOUBLE_EQ(back.fx, c.fx);
  EXPECT_DOUBLE_EQ(back.fy, c.fy);
  EXPECT_DOUBLE_EQ(back.cx, c.cx);
  EXPECT_DOUBLE_EQ(back.cy, c.cy);
  EXPECT_DOUBLE_EQ(back.doffs, 0);
  EXPECT_DOUBLE_EQ(back.baseline_mm, 150);
  EXPECT_EQ(back.width, 640);
  EXPECT_EQ(back.height, 480);
  EXPECT_EQ(back.ndisp, 64);
  EXPECT_EQ(back.extra, c.extra);
  EXPECT_THAT(ReadCalib(tmp / "none.txt"),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("none.txt")));
}

TEST(MiddleburyTest, ReadsTheFormOfThe2014DataSets) {
  // In the form the 2014 scenes are published in (the numbers are made
  // up): different principal points (doffs is their x difference) and
  // keys of their own after ndisp.
  ASSERT_OK_AND_ASSIGN(
      const Calib c,
      ParseCalib("cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]\n"
                 "cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]\n"
                 "doffs=131.111\nbaseline=193.001\nwidth=2964\nheight=1988\n"
                 "ndisp=280\nisint=0\nvmin=31\nvmax=257\ndyavg=0.918\n"
                 "dymax=1.516\n"));
  EXPECT_DOUBLE_EQ(c.fx, 3997.684);
  EXPECT_DOUBLE_EQ(c.cx, 1176.728);
  EXPECT_DOUBLE_EQ(c.cy, 1011.728);
  EXPECT_DOUBLE_EQ(c.doffs, 131.111);
  EXPECT_DOUBLE_EQ(c.baseline_mm, 193.001);
  EXPECT_EQ(c.width, 2964);
  EXPECT_EQ(c.ndisp, 280);
  ASSERT_EQ(c.extra.size(), 5u);
  EXPECT_EQ(c.extra[0], (std::pair<std::string, std::string>{"isint", "0"}));
  EXPECT_EQ(c.extra[4].first, "dymax");
  // Written again, cam1's principal point is cam0's + doffs.
  EXPECT_THAT(FormatCalib(c),
              HasSubstr("cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 "
                        "1]\ncam1=[3997.684 0 1307.839"));
}

// Found by middlebury_calib_fuzzer: a focal length of 1e-7 px was read, then
// written with 6 decimals as 0, which the reader refuses; doffs lost digits
// after the sixth significant one. Every number now reads back exactly.
TEST(MiddleburyTest, WhatIsReadIsWrittenSoThatItReadsBackTheSame) {
  ASSERT_OK_AND_ASSIGN(
      const Calib c,
      ParseCalib("cam0=[1000 0 599.5; 0 .0000001 449.5; 0 0 1]\n"
                 "doffs=1234.56789\nbaseline=0.0000003\nwidth=1200\n"
                 "height=900\nndisp=192\n"));
  const std::string text = FormatCalib(c);
  ASSERT_OK_AND_ASSIGN(const Calib back, ParseCalib(text));
  EXPECT_EQ(back.fy, 1e-7);
  EXPECT_EQ(back.doffs, 1234.56789);
  EXPECT_EQ(back.baseline_mm, 3e-7);
  EXPECT_EQ(FormatCalib(back), text);
}

TEST(MiddleburyTest, BadCalibNamesTheKey) {
  const std::string good = FormatCalib(Sample());
  auto without = [&](const std::string& key) {
    std::string out;
    for (size_t at = 0; at < good.size();) {
      const size_t end = good.find('\n', at);
      const std::string line = good.substr(at, end - at + 1);
      if (line.rfind(key + "=", 0) != 0) out += line;
      at = end + 1;
    }
    return out;
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {without("cam0"), "cam0 is missing"},
      {without("baseline"), "baseline is missing"},
      {without("width"), "width is missing"},
      {without("height"), "height is missing"},
      {without("ndisp"), "ndisp is missing"},
      {good + "doffs=x\n", "doffs is missing or not a number"},
      {"cam0=[1 2 3]\n" + without("cam0"), "cam0 is missing or not [fx"},
      {without("baseline") + "baseline=-3\n",
       "baseline is missing or not a "
       "positive number"},
  };
  for (const auto& [text, message] : cases) {
    EXPECT_THAT(ParseCalib(text), StatusIs(absl::StatusCode::kInvalidArgument,
                                           HasSubstr(message)))
        << text;
  }
  TempDir tmp;
  ASSERT_OK(WriteFileAtomically(tmp / kCalibFile, without("ndisp")));
  EXPECT_THAT(ReadCalib(tmp / kCalibFile),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("calib.txt: ndisp is missing")));
}

// Numbers a hostile or damaged calib.txt may hold: each refused naming the
// key, quoting a bounded prefix of the value or giving the limit.
TEST(MiddleburyTest, CalibNumbersAreBounded) {
  const std::string good = FormatCalib(Sample());
  auto with = [&](const std::string& key, const std::string& value) {
    std::string out;
    for (size_t at = 0; at < good.size();) {
      const size_t end = good.find('\n', at);
      const std::string line = good.substr(at, end - at + 1);
      out += line.rfind(key + "=", 0) == 0 ? key + "=" + value + "\n" : line;
      at = end + 1;
    }
    return out;
  };
  const int64_t max_width = DecodedImageLimits().max_width;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {with("width", "2147483648"),
       absl::StrCat("calib.txt width: 2147483648 is outside [1, ", max_width,
                    "]")},
      {with("height", "-480"), "calib.txt height: -480 is outside [1, "},
      {with("width", "99999999999999999999"),
       "calib.txt: width is missing or not a whole number: "
       "\"99999999999999999999\""},
      {with("width", "1048576") + "height=1048576\n",
       absl::StrCat("calib.txt pixels (width x height): 1048576 x 1048576 is "
                    "more than the limit of ",
                    DecodedImageLimits().max_pixels)},
      {with("ndisp", "0"), "calib.txt ndisp: 0 is outside [1, "},
      {with("ndisp", "4000000"),
       absl::StrCat("calib.txt ndisp: 4000000 is outside [1, ", max_width,
                    "]")},
      {with("cam0", "[nan 0 1; 0 1 1; 0 0 1]"), "cam0 is missing or not [fx"},
      {with("cam0", "[1 0 inf; 0 1 1; 0 0 1]"), "cam0 is missing or not [fx"},
      {with("cam0", "[1 0 1; 0 1 1; 0 0 1; 5]"), "cam0 is missing or not [fx"},
      {with("baseline", "inf"),
       "calib.txt: baseline is missing or not a positive number (mm): "
       "\"inf\""},
      {with("doffs", "nan"), "calib.txt: doffs is missing or not a number"},
      {good + "vmin=nan\n",
       "calib.txt: vmin is missing or not a finite number: \"nan\""},
      {good + "vmax=1e999\n", "calib.txt: vmax is missing or not a finite"},
  };
  for (const auto& [text, message] : cases) {
    EXPECT_THAT(ParseCalib(text), StatusIs(absl::StatusCode::kInvalidArgument,
                                           HasSubstr(message)))
        << text;
  }
  // A value of a megabyte is quoted by its first bytes and its size.
  const absl::Status s =
      ParseCalib(with("width", std::string(1 << 20, '7') + "x")).status();
  EXPECT_THAT(s, StatusIs(absl::StatusCode::kInvalidArgument,
                          HasSubstr("(1048577 bytes)")));
  EXPECT_LT(s.message().size(), 200u);
  // Finite bounds are kept as they are.
  ASSERT_OK_AND_ASSIGN(const Calib c, ParseCalib(good + "vmin=31\nvmax=257\n"));
  EXPECT_EQ(c.extra.back(),
            (std::pair<std::string, std::string>{"vmax", "257"}));
}

TEST(MiddleburyTest, MaskFromTruth) {
  cv::Mat disparity = (cv::Mat_<float>(1, 4) << 3.5f, kInf, 2.0f, 1.0f);
  const cv::Mat nonoccluded = (cv::Mat_<uint8_t>(1, 4) << 255, 255, 0, 255);
  const cv::Mat mask = MaskFromTruth(disparity, nonoccluded);
  EXPECT_EQ(mask.type(), CV_8UC1);
  EXPECT_EQ(mask.at<uint8_t>(0, 0), kMaskNonOccluded);
  EXPECT_EQ(mask.at<uint8_t>(0, 1), kMaskUnknown);
  EXPECT_EQ(mask.at<uint8_t>(0, 2), kMaskOccluded);
  EXPECT_EQ(mask.at<uint8_t>(0, 3), kMaskNonOccluded);
  // Without a visibility mask every known pixel is non-occluded.
  const cv::Mat all = MaskFromTruth(disparity, cv::Mat());
  EXPECT_EQ(cv::countNonZero(all == kMaskNonOccluded), 3);
}

TEST(MiddleburyTest, GroundTruthFilesReadBack) {
  TempDir tmp;
  cv::Mat disp0(3, 5, CV_32FC1, cv::Scalar(7.25f));
  disp0.at<float>(1, 2) = kInf;
  const cv::Mat mask = MaskFromTruth(disp0, cv::Mat());
  ASSERT_OK(WriteGroundTruth(tmp / "gt", disp0, mask));
  ASSERT_OK_AND_ASSIGN(const cv::Mat back,
                       ReadPfm(tmp / "gt" / kDisparity0File));
  ASSERT_EQ(back.size(), disp0.size());
  EXPECT_FLOAT_EQ(back.at<float>(0, 0), 7.25f);
  EXPECT_EQ(back.at<float>(1, 2), kInf);
  const cv::Mat mask_back =
      cv::imread((tmp / "gt" / kMask0File).string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::countNonZero(mask_back != mask), 0);
  EXPECT_FALSE(std::filesystem::exists(tmp / "gt" / kDisparity1File));
  ASSERT_OK(WriteGroundTruth(tmp / "gt", disp0, mask, disp0));
  EXPECT_TRUE(std::filesystem::exists(tmp / "gt" / kDisparity1File));
  EXPECT_THAT(WriteGroundTruth(tmp / "bad", disp0, cv::Mat(2, 2, CV_8UC1)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("all of one size")));
}

}  // namespace
}  // namespace hdrstereo::io
