// SPDX-License-Identifier: GPL-3.0-or-later
//
// Device calls that fail in the middle of a frame (fixture:
// capture_fixture.h): transient faults take the frame again from its start,
// permanent ones and a fault at every attempt fail the job naming each.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "tests/integration/capture_fixture.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;

// A camera that times out at every attempt at frame 5 (calls 6, 7, 8): the
// job fails naming each attempt, keeps the frames before, and the same plan
// submitted again takes only the missing ones.
TEST_F(CaptureTest, AFaultAtEveryAttemptFailsTheJobNamingEachAndAResubmitEnds) {
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = {{"camera", {{"timeout", {{"calls", {6, 7, 8}}}}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "f"}).exit_code, 0);
  CommandResult first = Cli({"capture", "stereo", "f", "--watch"});
  EXPECT_EQ(first.exit_code, 1);
  nlohmann::json failed = Job(1);
  EXPECT_EQ(failed["state"], "JOB_STATE_FAILED");
  EXPECT_THAT(
      failed.value("error", ""),
      HasSubstr(" failed 3 times: 1) capturing: camera timed out (simulated "
                "fault, call 6); 2) capturing: camera timed out (simulated "
                "fault, call 7); 3) capturing: camera timed out (simulated "
                "fault, call 8); nothing was recorded for it"));
  // Two warnings that took the frame again, and the failure: three device
  // errors.
  EXPECT_EQ(EventsLike("the frame is taken again from its start (attempt 2 "
                       "of at most 3)"),
            1);
  EXPECT_EQ(EventsLike("the frame is taken again from its start (attempt 3 "
                       "of at most 3)"),
            1);
  EXPECT_EQ(EventsOfKind("camera_timeout"), 3);
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "5");
  ExpectConsistentStore("f", 5);

  CommandResult again = Cli({"capture", "stereo", "f", "--watch"});
  ASSERT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_THAT(again.out, HasSubstr("resuming: 5 frames already recorded"));
  EXPECT_EQ(Sql("SELECT count(*) FROM captures"), "1");
  ExpectConsistentStore("f", 17);
  EXPECT_EQ(ExpectFilesMatchTheirRows("f"), 17);
}

// A fault that does not pass by itself (an exposure the camera does not
// offer) fails the job at once, naming the frame, the step and the error.
TEST_F(CaptureTest, APermanentDeviceFaultFailsTheFrameAtOnce) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "p"}).exit_code, 0);
  EXPECT_EQ(Cli({"capture", "stereo", "p", "--exposures", "1/16000",
                 "--no-ambient", "--watch"})
                .exit_code,
            1);
  const nlohmann::json failed = Job(1);
  EXPECT_EQ(failed["state"], "JOB_STATE_FAILED");
  // Through libgphoto2 the range is the PTP/IP camera's shutter speeds.
  const std::string outside =
      testing::TestsThroughPtpIp()
          ? "shutterspeed (/main/capturesettings/shutterspeed): exposure "
            "1/16000 s is outside the camera's range 1/3333 s .. 30 s (bulb "
            "is not used)"
          : "exposure 6.25e-05 s is outside the simulated camera's "
            "[0.000125, 30] s";
  EXPECT_THAT(failed.value("error", ""),
              HasSubstr(absl::StrCat(
                  "frame left view, stereo, 1-16000s: setting the exposure to "
                  "1-16000s: ",
                  outside,
                  "; not tried again: this fault does not pass by itself; "
                  "nothing was recorded for it")));
  EXPECT_EQ(EventsLike("taken again"), 0);
  EXPECT_EQ(EventsOfKind("camera_error"), 1);
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "0");
  ExpectNoTempFiles();
}

// A transient device fault in the middle of a frame: the frame is taken
// again from its start at the same boundary (one warning, counted as the
// device error it is; a fault flag also suspends the job until the stage
// shows it no more) and every frame is recorded once.
struct TransientFault {
  std::string name;
  nlohmann::json faults;        // the scene's
  std::string plan;             // "stereo" (17 frames) or "sl" (120)
  std::string warning;          // LIKE pattern of the warning that retakes
  std::string kind;             // the device error kind it counts as
  std::string suspension = "";  // LIKE pattern of its suspension, if any
};

void PrintTo(const TransientFault& fault, std::ostream* os) {
  *os << fault.name;
}

class TransientFaultCaptureTest
    : public CaptureTest,
      public ::testing::WithParamInterface<TransientFault> {};

TEST_P(TransientFaultCaptureTest, TheFrameIsTakenAgainAndRecordedOnce) {
  const TransientFault& fault = GetParam();
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = fault.faults;
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "t"}).exit_code, 0);
  CommandResult run = Cli({"capture", fault.plan, "t", "--watch"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err << daemon_log();
  const int frames = fault.plan == "sl" ? 120 : 17;
  EXPECT_EQ(JsonInt(Job(1)["progress"]["done"]), frames);
  EXPECT_EQ(EventsLike(fault.warning), 1)
      << Sql("SELECT group_concat(message, '\n') FROM job_events");
  EXPECT_EQ(EventsLike("(attempt "), 1);
  EXPECT_EQ(EventsOfKind(fault.kind), 1);
  EXPECT_EQ(Sql("SELECT count(*) FROM job_events WHERE kind != ''"), "1");
  EXPECT_EQ(EventsLike("suspended: "), fault.suspension.empty() ? 0 : 1);
  if (!fault.suspension.empty()) {
    EXPECT_EQ(EventsLike(fault.suspension), 1);
    EXPECT_EQ(EventsLike("resumed: the condition cleared"), 1);
  }
  ExpectConsistentStore("t", frames);
  EXPECT_EQ(ExpectFilesMatchTheirRows("t"), frames);
}

// The stereo capture's stage commands, with the simulated time at 0 (every
// move ends by the first status poll): 1 "get maxspeed", 2-3 the job's
// State(); frame 0: its conditions' State() 4-5, Home() ("home" 6, a poll
// 7), MoveTo(0) (State() 8-9, "move abs" 10, a poll 11); frames 1-8: the
// conditions' State() from 12; frame 9, the right view: State() 28-29,
// MoveTo(150) (State() 30-31, "move abs" 32, a poll 33); frames 10-16: State()
// 34-47; parking: MoveTo(0) (State() 48-49, "move abs" 50). The Zaber driver
// sends a command three times before its garbled or missing reply reaches
// the daemon.
INSTANTIATE_TEST_SUITE_P(
    DeviceFaults, TransientFaultCaptureTest,
    ::testing::Values(
        TransientFault{
            "StageGarbledOnAMove",
            {{"stage", {{"garbled", {{"calls", {32, 33, 34}}}}}}},
            "stereo",
            "frame right view, %: moving the stage to 150.000 mm: stage on % "
            "answered \"move abs %\" with garbage%; the stage is homed again "
            "and the frame is taken again from its start (attempt 2 of at "
            "most 3)",
            "stage_garbled"},
        TransientFault{
            "StageGarbledOnTheHoming",
            {{"stage", {{"garbled", {{"calls", {6, 7, 8}}}}}}},
            "stereo",
            "frame left view, %: homing the stage: stage on % answered "
            "\"home\" with garbage%; the stage is homed again and the frame is "
            "taken again from its start (attempt 2 of at most 3)",
            "stage_garbled"},
        TransientFault{
            "StageSilentOnAMove",
            {{"stage", {{"silent", {{"calls", {32, 33, 34}}}}}}},
            "stereo",
            "frame right view, %: moving the stage to 150.000 mm: stage on % "
            "did not answer \"move abs %\" within 500ms (3 tries); the stage "
            "is homed again and the frame is taken again from its start",
            "stage_silent"},
        TransientFault{
            "StageStallsOnAMove",
            {{"stage", {{"stall", {{"calls", {10}}}}}}},
            "stereo",
            "frame left view, %: moving the stage to 0.000 mm: move to 0.000 "
            "mm did not finish within 2s (target 0.000 mm, stopped at 0.000 "
            "mm); is the stage stalled?; the stage is homed again",
            "stage_stalled"},
        TransientFault{
            "StageFaultFlagOnAMove",
            {{"stage",
              {{"warning_window",
                {{"calls", {33}}, {"lasts", 4}, {"flag", "FS"}}}}}},
            "stereo",
            "frame right view, %: moving the stage to 150.000 mm: move to "
            "150.000 mm failed: stage reports FS %; the stage is homed again",
            "stage_flag",
            "suspended: the stage reports warning flags FS"},
        TransientFault{
            "StageGarbledWhileParking",
            {{"stage", {{"garbled", {{"calls", {50, 51, 52}}}}}}},
            "stereo",
            "parking the rig after the last frame: moving the stage to 0.000 "
            "mm: stage on % answered \"move abs 0\" with garbage%; the stage "
            "is homed again and it is parked again (attempt 2 of at most 3)",
            "stage_garbled"},
        TransientFault{
            "CameraTimeout",
            {{"camera", {{"timeout", {{"calls", {6}}}}}}},
            "stereo",
            "frame left view, %: capturing: camera timed out (simulated "
            "fault, call 6); the frame is taken again from its start (attempt "
            "2 of at most 3)",
            "camera_timeout"},
        // The simulated camera retries "busy" 5 times, like the driver.
        TransientFault{"CameraBusyPastTheDriversRetries",
                       {{"camera", {{"busy_first_calls", 6}}}},
                       "stereo",
                       "frame left view, %: capturing: camera busy (simulated "
                       "fault, call 6); the frame is taken again from its "
                       "start (attempt 2 of at most 3)",
                       "camera_busy"},
        // Lost for the one Show only: the projector checks fine right
        // after, so this is no suspension.
        TransientFault{
            "ProjectorShowFailsOnce",
            {{"projector", {{"lost", {{"calls", {40}}, {"lasts", 1}}}}}},
            "sl",
            "frame % view, pattern %: showing pattern %: projector lost "
            "(simulated fault%; the frame is taken again from its start "
            "(attempt 2 of at most 3)",
            "projector_error"}),
    [](const ::testing::TestParamInfo<TransientFault>& info) {
      return info.param.name;
    });

}  // namespace
}  // namespace hdrstereo
