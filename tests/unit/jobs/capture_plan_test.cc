// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/capture_plan.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

namespace hdrstereo::jobs {
namespace {

using ::testing::HasSubstr;

v1::CapturePlan Stereo() {
  v1::CapturePlan plan;
  plan.mutable_bracketed_stereo();
  return plan;
}

TEST(CapturePlanTest, DefaultStereoIsTheThesisBracketAtTwoViews) {
  absl::StatusOr<v1::CapturePlan> plan = NormalizePlan(Stereo(), {});
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_EQ(plan->bracketed_stereo().exposures_s_size(), 8);
  EXPECT_EQ(plan->bracketed_stereo().baseline_mm(), 150);
  std::vector<FrameSpec> frames = ExpandPlan(*plan, {}, 7);
  ASSERT_EQ(frames.size(), 17u);  // ambient + 2 x 8
  EXPECT_EQ(frames[0].role, io::FrameRole::kAmbient);
  EXPECT_EQ(frames[1].relative_stem, "captures/7/left/stereo/exp_1-15s");
  EXPECT_EQ(frames[8].relative_stem, "captures/7/left/stereo/exp_1-2000s");
  EXPECT_EQ(frames[9].relative_stem, "captures/7/right/stereo/exp_1-15s");
  EXPECT_EQ(frames[9].stage_position_mm, 150);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].sequence, static_cast<int>(i));
    EXPECT_TRUE(frames[i].projector_blank);
  }
}

TEST(CapturePlanTest, StructuredLightIs168FramesAt1024x768) {
  v1::CapturePlan request;
  request.mutable_structured_light();
  absl::StatusOr<v1::CapturePlan> plan = NormalizePlan(request, {});
  ASSERT_TRUE(plan.ok());
  std::vector<FrameSpec> frames = ExpandPlan(*plan, {}, 3);
  ASSERT_EQ(frames.size(), 168u);  // 2 views x 2 exposures x (40 + 2)
  std::set<std::string> names;
  for (const FrameSpec& f : frames) {
    names.insert(f.relative_stem);
    EXPECT_TRUE(f.pattern.has_value());
  }
  EXPECT_EQ(names.size(), 168u);
  EXPECT_EQ(frames[1].relative_stem,
            "captures/3/left/structured_light/sl_col_b00_inv_exp_1-30s");
}

TEST(CapturePlanTest, BadPlansNameTheField) {
  struct Case {
    std::function<void(v1::CapturePlan&)> edit;
    std::string expected;
  };
  std::vector<Case> cases = {
      {[](v1::CapturePlan& p) {
         p.mutable_bracketed_stereo()->add_exposures_s(-0.01);
       },
       "exposures_s[0] is -0.01"},
      {[](v1::CapturePlan& p) {
         for (int i = 0; i < 65; ++i) {
           p.mutable_bracketed_stereo()->add_exposures_s(0.01);
         }
       },
       "at most 64"},
      {[](v1::CapturePlan& p) {
         p.mutable_bracketed_stereo()->set_baseline_mm(200);
       },
       "beyond the stage travel of 150 mm"},
      {[](v1::CapturePlan& p) { p.mutable_bracketed_stereo()->set_views(17); },
       "views is 17"},
      {[](v1::CapturePlan& p) { p.mutable_structured_light()->set_iso(-5); },
       "iso is -5"},
      {[](v1::CapturePlan& p) { p.mutable_calibration()->set_poses(0); },
       "poses is 0"},
      {[](v1::CapturePlan&) {}, "plan must be one of"},
  };
  for (const Case& c : cases) {
    v1::CapturePlan plan;
    c.edit(plan);
    absl::StatusOr<v1::CapturePlan> normalized = NormalizePlan(plan, {});
    EXPECT_EQ(normalized.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(normalized.status().message()),
                HasSubstr(c.expected));
  }
}

}  // namespace
}  // namespace hdrstereo::jobs
