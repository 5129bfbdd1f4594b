// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/capture_plan.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "daemon/jobs/rig_calibration.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::jobs {
namespace {

using ::hdrstereo::testing::StatusIs;
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

TEST(CapturePlanTest, AutoBracketChoosesItsExposuresAtTheRig) {
  v1::CapturePlan request = Stereo();
  request.mutable_bracketed_stereo()->mutable_auto_bracket()->set_min_snr(20);
  ASSERT_OK_AND_ASSIGN(const v1::CapturePlan plan, NormalizePlan(request, {}));
  // No exposures until the rig has chosen; the defaults of the rest.
  EXPECT_TRUE(ChoosesExposuresAtTheRig(plan));
  EXPECT_TRUE(ExpandPlan(plan, {}, 7).empty());
  const v1::AutoBracket& a = plan.bracketed_stereo().auto_bracket();
  EXPECT_EQ(a.min_snr(), 20);
  // The camera's own format may be 8-bit: the closer step.
  EXPECT_EQ(a.max_step_stops(), hdr::kMaxStepStops8Bit);
  EXPECT_EQ(a.exclude_emitters_above(), 0);
  const hdr::AutoBracketOptions options = AutoBracketOptionsOf(a);
  EXPECT_EQ(options.min_snr, 20);
  EXPECT_EQ(options.max_step_stops, a.max_step_stops());
  EXPECT_FALSE(ChoosesExposuresAtTheRig(Stereo()));
  // Linear frames take the library's step, 8-bit ones the closer one; a
  // step the request gives is kept.
  for (const auto& [format, step] :
       {std::pair{v1::IMAGE_FORMAT_TIFF_16, 1.0},
        {v1::IMAGE_FORMAT_RAW, 1.0},
        {v1::IMAGE_FORMAT_JPEG, hdr::kMaxStepStops8Bit},
        {v1::IMAGE_FORMAT_PNG_8, hdr::kMaxStepStops8Bit}}) {
    v1::CapturePlan with_format = request;
    with_format.mutable_bracketed_stereo()->set_format(format);
    ASSERT_OK_AND_ASSIGN(const v1::CapturePlan normalized,
                         NormalizePlan(with_format, {}));
    EXPECT_EQ(normalized.bracketed_stereo().auto_bracket().max_step_stops(),
              step)
        << v1::ImageFormat_Name(format);
    with_format.mutable_bracketed_stereo()
        ->mutable_auto_bracket()
        ->set_max_step_stops(2);
    ASSERT_OK_AND_ASSIGN(const v1::CapturePlan given,
                         NormalizePlan(with_format, {}));
    EXPECT_EQ(given.bracketed_stereo().auto_bracket().max_step_stops(), 2);
  }

  hdr::AutoBracketResult chosen;
  chosen.exposures_s = {0.25, 0.125, 1.0 / 16};
  const v1::CapturePlan with = WithChosenExposures(plan, chosen);
  EXPECT_FALSE(ChoosesExposuresAtTheRig(with));
  const std::vector<FrameSpec> frames = ExpandPlan(with, {}, 7);
  ASSERT_EQ(frames.size(), 7u);            // ambient + 2 x 3
  EXPECT_EQ(frames[0].exposure_s, 0.125);  // the middle one
  EXPECT_EQ(frames[1].relative_stem, "captures/7/left/stereo/exp_1-4s");
  EXPECT_EQ(frames[6].relative_stem, "captures/7/right/stereo/exp_1-16s");

  chosen.pixels = 100;
  chosen.emitter_pixels = 10;
  chosen.uncovered_pixels = 9;
  chosen.min_snr = 40;
  chosen.probes = 5;
  v1::AutoBracketChoice proto;
  ToProto(chosen, &proto);
  EXPECT_EQ(proto.exposures_s_size(), 3);
  EXPECT_DOUBLE_EQ(proto.coverage(), 0.9);
  EXPECT_DOUBLE_EQ(proto.emitter_fraction(), 0.1);
  EXPECT_EQ(proto.probes(), 5);
  EXPECT_EQ(proto.reason(), chosen.Reason());
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

TEST(CapturePlanTest, CalibrationBoardDefaultsToNineBySixOf25Mm) {
  v1::CapturePlan request;
  request.mutable_calibration()->set_poses(4);
  ASSERT_OK_AND_ASSIGN(const v1::CapturePlan plan, NormalizePlan(request, {}));
  EXPECT_EQ(plan.calibration().board_columns(), 9);
  EXPECT_EQ(plan.calibration().board_rows(), 6);
  EXPECT_EQ(plan.calibration().board_square_mm(), 25);
  const calib::BoardSpec board = BoardOf(plan.calibration());
  EXPECT_EQ(board.inner_corners, cv::Size(9, 6));
  EXPECT_DOUBLE_EQ(board.square_m, 0.025);

  EXPECT_EQ(BoardOf(request.calibration()).inner_corners, cv::Size(9, 6))
      << "a plan stored before the board was named";
  EXPECT_DOUBLE_EQ(BoardOf(request.calibration()).square_m, 0.025);

  request.mutable_calibration()->set_board_columns(7);
  request.mutable_calibration()->set_board_rows(5);
  request.mutable_calibration()->set_board_square_mm(40);
  ASSERT_OK_AND_ASSIGN(const v1::CapturePlan own, NormalizePlan(request, {}));
  EXPECT_EQ(BoardOf(own.calibration()).inner_corners, cv::Size(7, 5));
  EXPECT_DOUBLE_EQ(BoardOf(own.calibration()).square_m, 0.040);
}

TEST(CapturePlanTest, ARecordedAutoBracketReadsBackOrNamesItsOwner) {
  hdr::AutoBracketResult chosen;
  chosen.exposures_s = {0.2, 0.1, 0.05};
  const nlohmann::json json = chosen;
  ASSERT_OK_AND_ASSIGN(const std::optional<hdr::AutoBracketResult> back,
                       RecordedAutoBracket("capture 3", json.dump()));
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->exposures_s, chosen.exposures_s);
  ASSERT_OK_AND_ASSIGN(const std::optional<hdr::AutoBracketResult> none,
                       RecordedAutoBracket("capture 3", ""));
  EXPECT_FALSE(none.has_value()) << "a capture that chose nothing";
  EXPECT_THAT(RecordedAutoBracket("capture 3", "{not json"),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("capture 3: ")));
}

// Hand-counted: 1 ambient frame (the bracket's middle, 0.25 s) and 2
// exposures at each of 2 views: 1.75 s of exposure, 5 s of overhead, one
// move of 50 mm at 20 mm/s (2.5 s) and its 1 s settle.
TEST(CapturePlanTest, ExpectedSecondsCountsExposuresOverheadAndMoves) {
  v1::CapturePlan plan;
  v1::BracketedStereoPlan* p = plan.mutable_bracketed_stereo();
  p->add_exposures_s(0.5);
  p->add_exposures_s(0.25);
  p->set_baseline_mm(50);
  p->set_settle_s(1);
  const RigLimits rig;
  ASSERT_OK_AND_ASSIGN(const v1::CapturePlan normal, NormalizePlan(plan, rig));
  const std::vector<FrameSpec> frames = ExpandPlan(normal, rig, 0);
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_DOUBLE_EQ(ExpectedSeconds(frames, SettingsOf(normal), rig), 10.25);
  // Without the ambient frame, and with a slower stage: 1.5 + 4 + 5 + 1.
  p->set_skip_ambient(true);
  ASSERT_OK_AND_ASSIGN(const v1::CapturePlan no_ambient,
                       NormalizePlan(plan, rig));
  EXPECT_DOUBLE_EQ(
      ExpectedSeconds(ExpandPlan(no_ambient, rig, 0), SettingsOf(no_ambient),
                      rig, {.stage_speed_mm_s = 10}),
      11.5);
}

// Every one of the 42 patterns of a 1024x768 projector is a change.
TEST(CapturePlanTest, ExpectedSecondsCountsEachPatternChange) {
  v1::CapturePlan plan;
  plan.mutable_structured_light()->add_exposures_s(0.1);
  plan.mutable_structured_light()->set_views(1);
  const RigLimits rig;
  ASSERT_OK_AND_ASSIGN(const v1::CapturePlan normal, NormalizePlan(plan, rig));
  const std::vector<FrameSpec> frames = ExpandPlan(normal, rig, 0);
  ASSERT_EQ(frames.size(), 42u);
  // 42 x (0.1 s exposure + 1 s overhead + 0.1 s pattern change).
  EXPECT_NEAR(ExpectedSeconds(frames, SettingsOf(normal), rig), 50.4, 1e-9);
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
      {[](v1::CapturePlan& p) {
         p.mutable_calibration()->set_poses(3);
         p.mutable_calibration()->set_board_columns(2);
       },
       "calibration.board_columns is 2 inner corners; use 3 to 100"},
      {[](v1::CapturePlan& p) {
         p.mutable_calibration()->set_poses(3);
         p.mutable_calibration()->set_board_rows(101);
       },
       "calibration.board_rows is 101 inner corners; use 3 to 100"},
      {[](v1::CapturePlan& p) {
         p.mutable_calibration()->set_poses(3);
         p.mutable_calibration()->set_board_square_mm(-4);
       },
       "calibration.board_square_mm is -4; use a size in mm above 0"},
      {[](v1::CapturePlan&) {}, "plan must be one of"},
      {[](v1::CapturePlan& p) {
         p.mutable_bracketed_stereo()->add_exposures_s(0.01);
         p.mutable_bracketed_stereo()->mutable_auto_bracket();
       },
       "give exposures_s or auto_bracket, not both"},
      {[](v1::CapturePlan& p) {
         p.mutable_bracketed_stereo()->mutable_auto_bracket()->set_min_snr(5);
       },
       "bracketed_stereo.auto_bracket.min_snr is 5; it must be in [10, 1000]"},
      {[](v1::CapturePlan& p) {
         p.mutable_bracketed_stereo()
             ->mutable_auto_bracket()
             ->set_exclude_emitters_above(0.5);
       },
       "bracketed_stereo.auto_bracket.exclude_emitters_above is 0.5"},
      {[](v1::CapturePlan& p) {
         p.mutable_bracketed_stereo()
             ->mutable_auto_bracket()
             ->set_max_uncovered_fraction(1);
       },
       "bracketed_stereo.auto_bracket.max_uncovered_fraction is 1"},
      {[](v1::CapturePlan& p) {
         p.mutable_bracketed_stereo()
             ->mutable_auto_bracket()
             ->set_max_exposure_s(-1);
       },
       "bracketed_stereo.auto_bracket.max_exposure_s is -1"},
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
