// SPDX-License-Identifier: GPL-3.0-or-later
//
// Calibration captures end to end (issue 24, item 3): the real daemon on
// simulated hardware whose board takes a pose per step, driven through the
// real CLI. Before each pose the job waits for the operator (`jobs
// continue`); a pose without the board is not kept; a waiting job survives
// a restart; a schedule never runs a calibration.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "absl/strings/str_cat.h"
#include "tests/support/daemon_fixture.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::testing::HasSubstr;

// The bundled checkerboard scene (eight board poses) at 600 x 450, so the
// daemon's board detection stays quick.
nlohmann::json SmallCheckerboard() {
  return {{"camera",
           {{"width", 600},
            {"height", 450},
            {"fx", 800},
            {"fy", 800},
            {"cx", 299.5},
            {"cy", 224.5}}}};
}

class CalibrationTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  void StartSim(const nlohmann::json& patch = SmallCheckerboard()) {
    if (scene_path_.empty()) scene_path_ = WriteScene("checkerboard", patch);
    StartDaemon({"--sim-scene", scene_path_.string()});
  }

  std::string Instruction(int64_t id) {
    return Job(id).value("instruction", "");
  }

  // Polls until the job waits with `instruction` (a state read just after a
  // continue may still be the previous pose's); false after 60 s.
  bool WaitForInstruction(int64_t id, const std::string& instruction) {
    for (int tries = 0; tries < 1200; ++tries) {
      const nlohmann::json job = Job(id);
      if (job.value("state", "") == "JOB_STATE_WAITING" &&
          job.value("instruction", "") == instruction) {
        return true;
      }
      absl::SleepFor(absl::Milliseconds(50));
    }
    return false;
  }

  // Continues the job with the CLI, which must succeed.
  void Continue(int64_t id) {
    CommandResult r = Cli({"jobs", "continue", std::to_string(id)});
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }

  fs::path scene_path_;
};

TEST_F(CalibrationTest, WaitsForTheOperatorBeforeEachPoseAndSurvivesARestart) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "cal"}).exit_code, 0);
  const int64_t id = Submit({"capture", "calibration", "cal", "--poses", "4"});
  ASSERT_GT(id, 0);
  for (int pose = 1; pose <= 4; ++pose) {
    SCOPED_TRACE(absl::StrCat("pose ", pose));
    ASSERT_TRUE(WaitForInstruction(
        id,
        absl::StrCat("place the board in pose ", pose, " of 4 and continue")))
        << Job(id).dump();
    EXPECT_EQ(FramesDone(id), 2 * (pose - 1));
    // `jobs show` tells the operator what to do and how to go on.
    CommandResult show = Cli({"jobs", "show", std::to_string(id)});
    EXPECT_THAT(show.out,
                HasSubstr(absl::StrCat("place the board in pose ", pose,
                                       " of 4 and continue (hdrstereo jobs "
                                       "continue ",
                                       id, ")")));
    if (pose == 3) {
      // A waiting job survives a restart: it waits again for the same pose.
      ASSERT_EQ(StopDaemon(), 0);
      StartSim();
      ASSERT_TRUE(WaitForInstruction(
          id, "place the board in pose 3 of 4 and continue"));
      EXPECT_EQ(FramesDone(id), 4);
    }
    Continue(id);
  }
  ASSERT_TRUE(WaitForJobState(id, "succeeded"));
  EXPECT_EQ(Instruction(id), "");
  ExpectConsistentStore("cal", 8);
  // Continuing a job that is not waiting names its state.
  CommandResult again = Cli({"jobs", "continue", std::to_string(id)});
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_THAT(again.err,
              HasSubstr(absl::StrCat("job ", id,
                                     " is succeeded; only a waiting job can "
                                     "be continued")));
  EXPECT_EQ(Cli({"jobs", "continue", "999"}).exit_code, 4);
  // Every continue is audited, as other job mutations are.
  EXPECT_EQ(Sql("SELECT count(*) FROM audit WHERE method = "
                "'/hdrstereo.v1.Jobs/Continue' AND status_code = 0"),
            "4");
}

TEST_F(CalibrationTest, APoseWithoutTheBoardIsNotKeptAndIsAskedForAgain) {
  // Pose 2 puts the board out of the camera's view.
  nlohmann::json patch = SmallCheckerboard();
  patch["calibration_board"] = {{"objects", {"board", "border"}},
                                {"poses",
                                 {{{"offset_mm", {0, 0, 0}}},
                                  {{"offset_mm", {3000, 0, 0}}},
                                  {{"offset_mm", {0, 50, 0}}}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "cal"}).exit_code, 0);
  const int64_t id = Submit({"capture", "calibration", "cal", "--poses", "3"});
  ASSERT_GT(id, 0);
  ASSERT_TRUE(
      WaitForInstruction(id, "place the board in pose 1 of 3 and continue"));
  Continue(id);
  // Pose 2 is asked for; continuing finds no board, so it is asked again.
  ASSERT_TRUE(
      WaitForInstruction(id, "place the board in pose 2 of 3 and continue"));
  Continue(id);
  ASSERT_TRUE(WaitForInstruction(
      id,
      "the board was not found in the left view of pose 2; place the board "
      "in pose 2 of 3 and continue"))
      << Job(id).dump();
  EXPECT_EQ(FramesDone(id), 2);  // pose 1 only
  EXPECT_EQ(EventsLike("pose 2 of 3: the board was not found in the left view"
                       "%the pose is not kept"),
            1);
  ASSERT_EQ(Cli({"jobs", "cancel", std::to_string(id)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(id, "cancelled"));
  ExpectConsistentStore("cal", 2);
}

TEST_F(CalibrationTest, AScheduleNeverRunsACalibration) {
  StartSim();
  const fs::path plan = dir_ / "plan.json";
  std::ofstream(plan) << R"({"sessionPattern": "n-{date}", "captures": [)"
                         R"({"calibration": {"poses": 4}}]})";
  CommandResult add = Cli({"schedule", "add", "nightly-cal", "--cron",
                           "0 2 * * *", "--plan", plan.string()});
  EXPECT_EQ(add.exit_code, 2) << "INVALID_ARGUMENT";
  EXPECT_THAT(add.err, HasSubstr("plan.captures[0] is a calibration: a "
                                 "schedule never runs one"));
  EXPECT_EQ(Sql("SELECT count(*) FROM schedules"), "0");
}

}  // namespace
}  // namespace hdrstereo
