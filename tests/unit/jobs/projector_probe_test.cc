// SPDX-License-Identifier: GPL-3.0-or-later
//
// The projector probe's search against a modelled projector whose latency
// is known, its options, the refresh-period arithmetic, and the plan
// options that use them.
#include "daemon/jobs/projector_probe.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "daemon/jobs/capture_plan.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::jobs {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

constexpr double kBlack = 20;
constexpr double kWhite = 180;

// A projector `latency` late seen by a camera exposing for `exposure`: the
// frame's mean level is black, white, or in between for the part of the
// exposure the white pattern shone. Records the delays asked for.
struct ModelledRig {
  absl::Duration latency;
  absl::Duration exposure = absl::ZeroDuration();
  std::vector<absl::Duration> asked = {};

  LevelAfter level_after() {
    return [this](absl::Duration delay) -> absl::StatusOr<double> {
      asked.push_back(delay);
      if (delay >= latency) return kWhite;
      if (delay + exposure <= latency) return kBlack;
      const double lit =
          absl::FDivDuration(delay + exposure - latency, exposure);
      return kBlack + lit * (kWhite - kBlack);
    };
  }
};

TEST(ProjectorProbeTest, FindsTheLatencyWithinOneStepForAnyLatency) {
  const ProbeOptions options{.step = absl::Milliseconds(20),
                             .max_delay = absl::Milliseconds(500)};
  for (int ms : {0, 1, 19, 20, 21, 55, 100, 333, 480, 500}) {
    ModelledRig rig{.latency = absl::Milliseconds(ms)};
    ASSERT_OK_AND_ASSIGN(
        ProbeResult result,
        SearchLatency(options, kBlack, kWhite, rig.level_after()));
    // The first step at or after the latency: never early, at most one
    // step late.
    EXPECT_GE(result.latency, rig.latency) << ms << " ms";
    EXPECT_LT(result.latency - rig.latency, options.step) << ms << " ms";
    EXPECT_EQ(result.step, options.step);
    EXPECT_EQ(result.black_level, kBlack);
    EXPECT_EQ(result.white_level, kWhite);
    EXPECT_DOUBLE_EQ(result.white_from, kBlack + 0.9 * (kWhite - kBlack));
    // Increasing delays from 0, stopping at the first white frame.
    ASSERT_EQ(rig.asked.size(), result.steps.size());
    for (size_t i = 0; i < rig.asked.size(); ++i) {
      EXPECT_EQ(rig.asked[i], options.step * static_cast<int64_t>(i));
      EXPECT_EQ(result.steps[i].delay, rig.asked[i]);
      EXPECT_EQ(result.steps[i].white, i + 1 == rig.asked.size());
    }
  }
}

TEST(ProjectorProbeTest, AFrameLitForPartOfItsExposureIsNotWhite) {
  // 95 ms latency, 50 ms exposure: the frame at 60 ms is lit for 15 of its
  // 50 ms, the one at 80 ms for 35 ms (70 %, under the 90 % needed); the
  // one at 100 ms all the time.
  ModelledRig rig{.latency = absl::Milliseconds(95),
                  .exposure = absl::Milliseconds(50)};
  ASSERT_OK_AND_ASSIGN(ProbeResult result,
                       SearchLatency({.step = absl::Milliseconds(20),
                                      .max_delay = absl::Milliseconds(300)},
                                     kBlack, kWhite, rig.level_after()));
  EXPECT_EQ(result.latency, absl::Milliseconds(100));
  ASSERT_EQ(result.steps.size(), 6u);
  EXPECT_DOUBLE_EQ(result.steps[3].level, kBlack + 0.3 * (kWhite - kBlack));
  EXPECT_DOUBLE_EQ(result.steps[4].level, kBlack + 0.7 * (kWhite - kBlack));
  EXPECT_FALSE(result.steps[4].white);
}

TEST(ProjectorProbeTest, NoWhiteFrameUpToTheLongestDelayIsOutOfRange) {
  ModelledRig rig{.latency = absl::Milliseconds(700)};
  EXPECT_THAT(SearchLatency({.step = absl::Milliseconds(100),
                             .max_delay = absl::Milliseconds(500)},
                            kBlack, kWhite, rig.level_after()),
              StatusIs(absl::StatusCode::kOutOfRange,
                       HasSubstr("no frame was white up to 0.5 s after the "
                                 "white pattern was shown")));
  EXPECT_EQ(rig.asked.size(), 6u);  // 0, 0.1, ..., 0.5 s
}

TEST(ProjectorProbeTest, ReferencesWithoutContrastAreRefusedBeforeAnyFrame) {
  ModelledRig rig{.latency = absl::Milliseconds(10)};
  EXPECT_THAT(
      SearchLatency({}, 50, 51, rig.level_after()),
      StatusIs(absl::StatusCode::kFailedPrecondition,
               HasSubstr("the camera does not see the projector: a frame of "
                         "white (mean level 51.0) is not brighter than one "
                         "of black (50.0) by 2 levels")));
  EXPECT_TRUE(rig.asked.empty());
}

TEST(ProjectorProbeTest, AFailingFrameEndsTheSearchWithItsError) {
  int calls = 0;
  EXPECT_THAT(SearchLatency({}, kBlack, kWhite,
                            [&](absl::Duration) -> absl::StatusOr<double> {
                              if (++calls == 3) {
                                return absl::DeadlineExceededError(
                                    "capture: no answer");
                              }
                              return kBlack;
                            }),
              StatusIs(absl::StatusCode::kDeadlineExceeded,
                       HasSubstr("capture: no answer")));
  EXPECT_EQ(calls, 3);
}

TEST(ProjectorProbeTest, OptionsTakeDefaultsAndNameTheBadField) {
  ASSERT_OK_AND_ASSIGN(ProbeOptions defaults, ProbeOptionsFrom({}, "options"));
  EXPECT_EQ(defaults.step, absl::Milliseconds(20));
  EXPECT_EQ(defaults.max_delay, absl::Milliseconds(500));
  EXPECT_DOUBLE_EQ(defaults.exposure_s, 1.0 / 125);
  v1::ProjectorProbeOptions round_trip = ToProto(defaults);
  EXPECT_DOUBLE_EQ(round_trip.step_s(), 0.02);
  EXPECT_DOUBLE_EQ(round_trip.max_delay_s(), 0.5);

  v1::ProjectorProbeOptions proto;
  proto.set_step_s(-0.01);
  EXPECT_THAT(ProbeOptionsFrom(proto, "options"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("options.step_s is -0.01")));
  proto.set_step_s(0.05);
  proto.set_max_delay_s(std::nan(""));
  EXPECT_THAT(ProbeOptionsFrom(proto, "x.probe"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("x.probe.max_delay_s is nan")));
  proto.set_max_delay_s(0.01);
  EXPECT_THAT(ProbeOptionsFrom(proto, "options"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("options.max_delay_s (0.01 s) is shorter "
                                 "than options.step_s (0.05 s)")));
  proto.set_step_s(0.001);
  proto.set_max_delay_s(1);
  EXPECT_THAT(ProbeOptionsFrom(proto, "options"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("more than 100 frames")));
  proto.set_step_s(0.01);  // 0 .. 1 s: 101 frames
  EXPECT_THAT(ProbeOptionsFrom(proto, "options"),
              StatusIs(absl::StatusCode::kInvalidArgument));
  proto.set_max_delay_s(0.99);  // 100 frames
  EXPECT_OK(ProbeOptionsFrom(proto, "options").status());
  proto.set_exposure_s(31);
  EXPECT_THAT(ProbeOptionsFrom(proto, "options"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("options.exposure_s is 31")));
}

TEST(ProjectorProbeTest, ExposuresOfWholeRefreshPeriods) {
  // 60 Hz: 1/60, 1/30, 1/15 s are 1, 2, 4 periods; 1/125 s is half of
  // one; 1/50 s is 1.2.
  for (double e : {1.0 / 60, 1.0 / 30, 1.0 / 15, 0.5}) {
    EXPECT_TRUE(IsWholeRefreshPeriods(e, 60)) << e;
  }
  for (double e : {1.0 / 125, 1.0 / 50, 1.0 / 40}) {
    EXPECT_FALSE(IsWholeRefreshPeriods(e, 60)) << e;
  }
  EXPECT_TRUE(IsWholeRefreshPeriods(1.0 / 60, 59.94));  // within 2 %
  EXPECT_DOUBLE_EQ(RoundToRefreshPeriods(1.0 / 125, 60), 1.0 / 60);
  EXPECT_DOUBLE_EQ(RoundToRefreshPeriods(1.0 / 40, 60), 1.0 / 30);
  EXPECT_DOUBLE_EQ(RoundToRefreshPeriods(0.3, 60), 18.0 / 60);
}

TEST(ProjectorProbeTest, PlansRoundExposuresAndCompleteTheProbeOptions) {
  RigLimits rig;
  rig.projector_refresh_hz = 60;
  v1::CapturePlan plan;
  v1::StructuredLightPlan* sl = plan.mutable_structured_light();
  sl->add_exposures_s(1.0 / 125);
  sl->add_exposures_s(1.0 / 40);
  sl->set_round_exposures_to_refresh(true);
  sl->mutable_projector_probe()->set_step_s(0.05);
  ASSERT_OK_AND_ASSIGN(v1::CapturePlan normal, NormalizePlan(plan, rig));
  EXPECT_THAT(normal.structured_light().exposures_s(),
              ::testing::ElementsAre(1.0 / 60, 1.0 / 30));
  EXPECT_DOUBLE_EQ(normal.structured_light().projector_probe().step_s(), 0.05);
  EXPECT_DOUBLE_EQ(normal.structured_light().projector_probe().max_delay_s(),
                   0.5);

  // Without a known refresh rate rounding is refused; a bad probe option is
  // named with the plan's field.
  rig.projector_refresh_hz = 0;
  EXPECT_THAT(NormalizePlan(plan, rig),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("structured_light.round_exposures_to_refresh"
                                 ": the projector does not report")));
  sl->set_round_exposures_to_refresh(false);
  sl->mutable_projector_probe()->set_max_delay_s(11);
  EXPECT_THAT(NormalizePlan(plan, rig),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("structured_light.projector_probe."
                                 "max_delay_s is 11")));
  // No probe unless asked.
  sl->clear_projector_probe();
  ASSERT_OK_AND_ASSIGN(normal, NormalizePlan(plan, rig));
  EXPECT_FALSE(normal.structured_light().has_projector_probe());
}

}  // namespace
}  // namespace hdrstereo::jobs
