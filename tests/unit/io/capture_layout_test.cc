// SPDX-License-Identifier: GPL-3.0-or-later
//
// The capture layout: exposure tags, frame stems of every role, and paths
// parsed back into what wrote them; names that do not fit are refused with
// the part that does not.
#include "processing/io/capture_layout.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "tests/support/status_matchers.h"

namespace hdrstereo::io {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

TEST(CaptureLayoutTest, ExposureTags) {
  EXPECT_EQ(ExposureTag(1.0 / 125), "1-125s");
  EXPECT_EQ(ExposureTag(0.5), "0.5s");
  EXPECT_EQ(ExposureTag(2), "2s");
}

TEST(CaptureLayoutTest, ExposureTagsAsCaptureJobsWriteThem) {
  EXPECT_DOUBLE_EQ(ParseExposureTag("1-30s").value_or(0), 1.0 / 30);
  EXPECT_DOUBLE_EQ(ParseExposureTag("1-125s").value_or(0), 1.0 / 125);
  EXPECT_DOUBLE_EQ(ParseExposureTag("0.5s").value_or(0), 0.5);
  EXPECT_DOUBLE_EQ(ParseExposureTag("2s").value_or(0), 2.0);
  EXPECT_FALSE(ParseExposureTag("1-0s").has_value());
  EXPECT_FALSE(ParseExposureTag("fast").has_value());
  EXPECT_FALSE(ParseExposureTag("s").has_value());
}

TEST(CaptureLayoutTest, ViewNames) {
  EXPECT_EQ(ViewName(0), "left");
  EXPECT_EQ(ViewName(1, 2), "right");
  EXPECT_EQ(ViewName(1, 3), "view1");
  EXPECT_EQ(ParseViewName("left"), 0);
  EXPECT_EQ(ParseViewName("right"), 1);
  EXPECT_EQ(ParseViewName("view12"), 12);
  EXPECT_FALSE(ParseViewName("centre").has_value());
  EXPECT_FALSE(ParseViewName("view").has_value());
}

TEST(CaptureLayoutTest, StemsOfEveryRoleParseBack) {
  struct Case {
    std::string view;
    FrameKey key;
    std::string stem;
  };
  auto key = [](FrameRole role, double exposure_s, std::string pattern,
                bool inverse, int pose) {
    FrameKey k;
    k.role = role;
    k.exposure_s = exposure_s;
    k.pattern = std::move(pattern);
    k.inverse = inverse;
    k.pose = pose;
    return k;
  };
  const std::vector<Case> cases = {
      {"left", key(FrameRole::kAmbient, 1.0 / 60, "", false, 0),
       "captures/7/left/ambient/exp_1-60s"},
      {"right", key(FrameRole::kStereo, 0.5, "", false, 0),
       "captures/7/right/stereo/exp_0.5s"},
      {"view2", key(FrameRole::kStructuredLight, 1.0 / 30, "col_b03", true, 0),
       "captures/7/view2/structured_light/sl_col_b03_inv_exp_1-30s"},
      {"left", key(FrameRole::kStructuredLight, 1.0 / 125, "white", false, 0),
       "captures/7/left/structured_light/sl_white_exp_1-125s"},
      {"right", key(FrameRole::kCalibration, 0, "", false, 4),
       "captures/7/right/calibration/pose_04"},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(FrameStem(7, c.view, c.key), c.stem);
    ASSERT_OK_AND_ASSIGN(const FramePath p, ParseFramePath(c.stem + ".png"));
    EXPECT_EQ(p.capture_id, 7);
    EXPECT_EQ(p.view, c.view);
    EXPECT_EQ(p.view_index, ParseViewName(c.view));
    EXPECT_EQ(p.key.role, c.key.role);
    EXPECT_DOUBLE_EQ(p.key.exposure_s, c.key.exposure_s);
    EXPECT_EQ(p.key.pattern, c.key.pattern);
    EXPECT_EQ(p.key.inverse, c.key.inverse);
    EXPECT_EQ(p.key.pose, c.key.pose);
  }
  EXPECT_EQ(KindOfRole(FrameRole::kAmbient), CaptureKind::kBracketedStereo);
  EXPECT_EQ(KindOfRole(FrameRole::kStereo), CaptureKind::kBracketedStereo);
  EXPECT_EQ(KindOfRole(FrameRole::kStructuredLight),
            CaptureKind::kStructuredLight);
  EXPECT_EQ(KindOfRole(FrameRole::kCalibration), CaptureKind::kCalibration);
  EXPECT_EQ(TruthDir(3), "captures/3/truth");
  EXPECT_EQ(RoleDir(3, "left", FrameRole::kStereo), "captures/3/left/stereo");
  // One-digit bit numbers are read as the capture jobs write them.
  ASSERT_OK_AND_ASSIGN(
      const FramePath p,
      ParseFramePath("captures/1/left/structured_light/sl_row_b2_exp_2s.tif"));
  EXPECT_EQ(p.key.pattern, "row_b02");
}

TEST(CaptureLayoutTest, PathsOutsideTheLayoutNameThePart) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"captures/1/left/stereo", "is not captures/<id>/<view>/<role>/<file>"},
      {"frames/1/left/stereo/exp_2s.png", "is not captures/"},
      {"captures/x/left/stereo/exp_2s.png", "\"x\" is not a capture id"},
      {"captures/1/middle/stereo/exp_2s.png", "\"middle\" is not a view"},
      {"captures/1/left/dark/exp_2s.png", "unknown frame role \"dark\""},
      {"captures/1/left/stereo/pose_01.png",
       "\"pose_01.png\" is not a stereo frame name"},
      {"captures/1/left/structured_light/sl_col_bx_exp_2s.png",
       "is not a structured_light frame name"},
      {"captures/1/left/structured_light/sl_col_b01.png",
       "is not a structured_light frame name"},
      {"captures/1/left/calibration/pose_x.png",
       "is not a calibration frame name"},
  };
  for (const auto& [path, message] : cases) {
    EXPECT_THAT(
        ParseFramePath(path),
        StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(message)))
        << path;
  }
}

TEST(CaptureLayoutTest, KindAndRoleNamesRoundTrip) {
  for (CaptureKind k :
       {CaptureKind::kBracketedStereo, CaptureKind::kStructuredLight,
        CaptureKind::kCalibration}) {
    ASSERT_OK_AND_ASSIGN(const CaptureKind parsed,
                         ParseCaptureKind(CaptureKindName(k)));
    EXPECT_EQ(parsed, k);
  }
  for (FrameRole r : {FrameRole::kAmbient, FrameRole::kStereo,
                      FrameRole::kStructuredLight, FrameRole::kCalibration}) {
    ASSERT_OK_AND_ASSIGN(const FrameRole parsed,
                         ParseFrameRole(FrameRoleName(r)));
    EXPECT_EQ(parsed, r);
  }
  EXPECT_THAT(ParseCaptureKind("hdr"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("unknown capture kind \"hdr\"")));
}

}  // namespace
}  // namespace hdrstereo::io
