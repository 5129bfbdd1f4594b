// SPDX-License-Identifier: GPL-3.0-or-later
//
// Chaos: one structured-light capture on simulated hardware that meets, at
// random frames, the camera returning the previous file, the camera
// dropping off the bus, a stage whose replies arrive garbled, and a kill -9
// of the daemon. At the end every planned frame is there exactly once, each
// file matches its row (sha256 and EXIF), nothing else is on disk and the
// database is intact.
//
// The frames are drawn from a seed the test prints: HDRSTEREO_CHAOS_SEED
// (default kDefaultSeed) reproduces a run. Every wait is bounded; nothing is
// asserted about wall-clock time.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "tests/support/daemon_fixture.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::SmallLabLamp;

constexpr uint64_t kDefaultSeed = 21;

// The Zaber driver resends a command whose reply is garbled twice
// (ZaberOptions::retries); a burst one longer than that reaches the daemon.
constexpr int kGarbledReplies = 3;

enum class Fault { kPreviousFile, kDisconnect, kStageGarble, kKill };

const char* Name(Fault fault) {
  switch (fault) {
    case Fault::kPreviousFile:
      return "previous file";
    case Fault::kDisconnect:
      return "camera disconnect";
    case Fault::kStageGarble:
      return "stage garble";
    case Fault::kKill:
      return "kill -9";
  }
  return "?";
}

struct Planned {
  Fault fault;
  int frame;  // the sequence number of the frame it is aimed at
};

// 7 + 7 Gray-code bits for SmallLabLamp's 128 x 96 projector: per view and
// exposure, each bit and its inverse for columns and rows, plus white and
// black.
int PlannedFrames(int views, int exposures, int projector_width,
                  int projector_height) {
  auto bits = [](int size) {
    int b = 0;
    while ((1 << b) < size) ++b;
    return b;
  };
  return views * exposures *
         (2 * (bits(projector_width) + bits(projector_height)) + 2);
}

uint64_t ChaosSeed() {
  uint64_t seed = kDefaultSeed;
  const char* env = std::getenv("HDRSTEREO_CHAOS_SEED");
  if (env != nullptr && !absl::SimpleAtoi(env, &seed)) {
    ADD_FAILURE() << "HDRSTEREO_CHAOS_SEED=\"" << env << "\" is not a number";
  }
  return seed;
}

// One frame for each fault, drawn from `seed`: inside the capture (not its
// first or last few frames), at least kGap frames apart so that each fault
// is over before the next, and the stage garble away from the boundaries
// where the stage moves (the first frame and the change of view), since a
// move is not retried (see docs/reliability.md, "Not done yet").
std::vector<Planned> Draw(uint64_t seed, int total) {
  constexpr int kGap = 12;
  std::mt19937_64 rng(seed);
  auto frame = [&] { return 6 + static_cast<int>(rng() % (total - 14)); };
  for (int attempt = 0; attempt < 100000; ++attempt) {
    std::vector<Planned> faults = {{Fault::kPreviousFile, frame()},
                                   {Fault::kDisconnect, frame()},
                                   {Fault::kStageGarble, frame()},
                                   {Fault::kKill, frame()}};
    bool ok = std::abs(faults[2].frame - total / 2) > 4;
    for (size_t i = 0; i < faults.size() && ok; ++i) {
      for (size_t j = i + 1; j < faults.size() && ok; ++j) {
        ok = std::abs(faults[i].frame - faults[j].frame) >= kGap;
      }
    }
    if (ok) {
      std::sort(
          faults.begin(), faults.end(),
          [](const Planned& a, const Planned& b) { return a.frame < b.frame; });
      return faults;
    }
  }
  return {};
}

// The scene's fault triggers for one daemon run that starts the capture at
// frame `first` (the first frame not yet recorded): the simulator counts
// camera captures and stage commands from 1 in each run. `faults` are the
// camera and stage faults aimed at frames >= first that this run must fire.
//
// Camera: frame f is capture call f - first + 1, plus one for each earlier
// fault of this run that made a frame be taken again (the previous file is
// retaken, the frame the camera dropped is retaken once it is back).
//
// Stage, as the daemon's sequence of commands goes with the simulated time
// at 0 (every move ends by the first status poll): 1 "get maxspeed" when the
// driver opens; the job's State() ("get pos", "warnings") and Home()
// ("home", one status poll); then at every frame boundary the suspenders'
// State(), and a MoveTo (State(), "move abs", one poll) where the stage
// moves: at the first boundary, at the change of view, and after every
// suspension together with a Home(). So boundary f > first asks "get pos"
// as command 12 + 2 (f - first - 1), 4 later past a change of view, 8 later
// after each camera drop (Home and MoveTo after the suspension).
nlohmann::json FaultsFor(int first, int view_change,
                         const std::vector<Planned>& faults) {
  nlohmann::json camera = nlohmann::json::object();
  nlohmann::json stage = nlohmann::json::object();
  int retaken = 0;
  int drops = 0;
  for (const Planned& p : faults) {
    const int call = p.frame - first + 1 + retaken;
    switch (p.fault) {
      case Fault::kPreviousFile:
        camera["previous_file"] = {{"calls", {call}}};
        ++retaken;
        break;
      case Fault::kDisconnect:
        camera["disconnect"] = {{"calls", {call}}};
        // The first reopen fails, the second (after the backoff) succeeds.
        camera["disconnect_failed_reopens"] = 1;
        ++retaken;
        ++drops;
        break;
      case Fault::kStageGarble: {
        int command = 12 + 2 * (p.frame - first - 1) + 8 * drops;
        if (first < view_change && p.frame > view_change) command += 4;
        std::vector<int> burst;
        for (int i = 0; i < kGarbledReplies; ++i) burst.push_back(command + i);
        stage["garbled"] = {{"calls", burst}};
        break;
      }
      case Fault::kKill:
        break;
    }
  }
  return {{"camera", camera}, {"stage", stage}};
}

class ChaosTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  // Starts the daemon on the data root with a scene whose faults fire at
  // `faults` for a run that begins at frame `first`.
  void StartRun(int run, int first, int view_change,
                const std::vector<Planned>& faults) {
    nlohmann::json patch = SmallLabLamp();
    patch["seed"] = static_cast<int>(seed_ % (1 << 30));
    patch["faults"] = FaultsFor(first, view_change, faults);
    std::cout << "run " << run << " from frame " << first
              << ", faults: " << patch["faults"].dump() << std::endl;
    const std::filesystem::path scene = WriteScene("lab-lamp", patch);
    StartDaemon({"--sim-scene", scene.string(), "--sim-time-scale", "0"});
  }

  int64_t Count(const std::string& query) {
    int64_t n = -1;
    EXPECT_TRUE(absl::SimpleAtoi(Sql(query), &n)) << query;
    return n;
  }

  // The frame (progress) at which the first event whose message is LIKE
  // `pattern` was recorded; -1 when there is none.
  int64_t FrameOfEvent(const std::string& pattern) {
    return Count(absl::StrCat(
        "SELECT coalesce(min(progress_done), -1) FROM job_events WHERE "
        "message LIKE '",
        pattern, "'"));
  }

  uint64_t seed_ = ChaosSeed();
};

TEST_F(ChaosTest, StructuredLightSurvivesEveryFaultAtRandomFrames) {
  const int total = PlannedFrames(/*views=*/2, /*exposures=*/2, 128, 96);
  const int view_change = total / 2;  // views are taken one after the other
  const std::vector<Planned> plan = Draw(seed_, total);
  ASSERT_EQ(plan.size(), 4u) << "no frames for the faults";
  std::string drawn;
  for (const Planned& p : plan) {
    absl::StrAppend(&drawn, drawn.empty() ? "" : ", ", Name(p.fault),
                    " at frame ", p.frame);
  }
  std::cout << "chaos seed " << seed_ << " (HDRSTEREO_CHAOS_SEED=" << seed_
            << " reproduces it): " << drawn << std::endl;
  RecordProperty("chaos_seed", std::to_string(seed_));
  RecordProperty("chaos_frames", drawn);
  const auto kill = std::find_if(plan.begin(), plan.end(), [](const auto& p) {
    return p.fault == Fault::kKill;
  });
  const std::vector<Planned> before(plan.begin(), kill);
  const absl::Time start = absl::Now();

  // Run 1: from the first frame to the kill.
  StartRun(1, 0, view_change, before);
  ASSERT_EQ(Cli({"session", "create", "chaos"}).exit_code, 0);
  const int64_t job = Submit({"capture", "sl", "chaos"});
  ASSERT_GT(job, 0);
  EXPECT_EQ(JsonInt(Job(job)["progress"]["total"]), total);
  const absl::Time deadline = absl::Now() + absl::Seconds(180);
  nlohmann::json polled;
  for (;;) {
    polled = Job(job);
    const std::string state = polled.value("state", "");
    if (JsonInt(polled["progress"]["done"]) >= kill->frame ||
        (state != "JOB_STATE_RUNNING" && state != "JOB_STATE_PAUSED" &&
         state != "JOB_STATE_QUEUED") ||
        absl::Now() > deadline) {
      break;
    }
    absl::SleepFor(absl::Milliseconds(5));
  }
  ASSERT_GE(JsonInt(polled["progress"]["done"]), kill->frame)
      << "the capture did not reach the kill: " << polled.dump() << "\n"
      << daemon_log();
  KillDaemon();
  const std::string first_log = daemon_log();
  // Where the next run starts: the frames recorded (and committed) so far.
  const int64_t recorded = Count("SELECT count(*) FROM frames");
  ASSERT_GE(recorded, kill->frame);
  ASSERT_LT(recorded, total) << "the capture finished before the kill";

  // Run 2: the restarted daemon resumes the interrupted job; the faults
  // after the kill are aimed at frames it has not taken yet.
  std::vector<Planned> after(kill + 1, plan.end());
  for (Planned& p : after) {
    p.frame = std::max(p.frame, static_cast<int>(recorded) + 2);
  }
  StartRun(2, static_cast<int>(recorded), view_change, after);
  ASSERT_TRUE(WaitForJobState(job, "succeeded", absl::Seconds(300)))
      << first_log << daemon_log();
  const absl::Duration run_time = absl::Now() - start;

  // Every planned frame exactly once, each file as its row says, nothing
  // else on disk, the database intact.
  const nlohmann::json finished = Job(job);
  EXPECT_EQ(JsonInt(finished["progress"]["done"]), total);
  EXPECT_EQ(Count("SELECT count(*) FROM captures"), 1);
  EXPECT_EQ(Count("SELECT count(*) FROM jobs"), 1);
  EXPECT_EQ(Count("SELECT count(DISTINCT capture_id || ':' || sequence) "
                  "FROM frames"),
            total);
  ExpectConsistentStore("chaos", total);
  EXPECT_EQ(ExpectFilesMatchTheirRows("chaos"), total);
  ExpectNoTempFiles();

  // Each fault fired once, where it was aimed, and was handled as it
  // should be.
  const int64_t previous = EventsLike("already taken in this capture");
  const int64_t drops = EventsLike("the camera dropped (camera disconnected");
  const int64_t camera_suspensions =
      EventsLike("suspended: camera disconnected");
  const int64_t stage_suspensions = EventsLike(
      "suspended: the stage does not read back: stage on % answered % with "
      "garbage");
  const int64_t suspensions = EventsLike("suspended: ");
  const int64_t resumptions = EventsLike("resumed: the condition cleared");
  const int64_t interruptions =
      Count(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ", job,
                         " AND state = 'interrupted'"));
  const int64_t retakes =
      EventsLike("taking it again") + EventsLike("the frame is taken again");
  EXPECT_EQ(previous, 1);
  EXPECT_EQ(drops, 1);
  EXPECT_EQ(camera_suspensions, 1);
  EXPECT_EQ(stage_suspensions, 1);
  EXPECT_EQ(suspensions, 2);
  EXPECT_EQ(resumptions, 2);
  EXPECT_EQ(interruptions, 1);
  EXPECT_EQ(retakes, 2);
  // The restarted daemon took up exactly the frames not yet recorded.
  EXPECT_EQ(Count(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id "
                               "= ",
                               job, " AND step = 'resuming: ", recorded,
                               " frames already recorded'")),
            1);
  EXPECT_EQ(Count("SELECT count(*) FROM job_events WHERE level = 'error'"), 0);
  // The camera is back and the rig idle.
  const nlohmann::json status = CliJson({"hw", "status"});
  EXPECT_EQ(status["camera"]["state"], "DEVICE_STATE_CONNECTED");
  EXPECT_EQ(status["stage"]["state"], "DEVICE_STATE_CONNECTED");

  // Where each fault fired: the frames recorded when its event was.
  const std::string figures = absl::StrFormat(
      "seed %d: %d/%d frames; previous file after %d frames (%d fired), "
      "camera drop after %d (%d), stage garble after %d (%d), kill -9 after "
      "%d (%d restart); %d retakes, %d suspensions, %d resumptions; %.1f s",
      seed_, Count("SELECT count(*) FROM frames"), total,
      FrameOfEvent("%already taken in this capture%"), previous,
      FrameOfEvent("%the camera dropped%"), drops,
      FrameOfEvent("suspended: the stage does not read back%"),
      stage_suspensions, recorded, interruptions, retakes, suspensions,
      resumptions, absl::ToDoubleSeconds(run_time));
  std::cout << "chaos figures: " << figures << std::endl;
  RecordProperty("chaos_figures", figures);
}

}  // namespace
}  // namespace hdrstereo
