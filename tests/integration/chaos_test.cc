// SPDX-License-Identifier: GPL-3.0-or-later
//
// Chaos: one structured-light capture on simulated hardware that meets, at
// random frames, the camera returning the previous file, the camera
// dropping off the bus, a camera capture that times out, a burst of garbled
// stage replies, a stage that does not answer, and a kill -9 of the daemon.
// The stage faults land on the conditions' check at a frame boundary or on
// a command that moves the stage (a homing, a move). At the end every
// planned frame is there exactly once, each file matches its row (sha256
// and EXIF), nothing else is on disk and the database is intact.
//
// The frames are drawn from a seed the test prints: HDRSTEREO_CHAOS_SEED
// (default kDefaultSeed) reproduces a run. Every wait is bounded; nothing is
// asserted about wall-clock time.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_replace.h"
#include "absl/time/clock.h"
#include "tests/support/daemon_fixture.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::SmallLabLamp;

constexpr uint64_t kDefaultSeed = 21;

// The Zaber driver sends a command up to three times when its reply is
// garbled or missing (ZaberOptions::retries); a burst of three reaches the
// daemon.
constexpr int kBurst = 3;

enum class Fault {
  kPreviousFile,
  kDisconnect,
  kCameraTimeout,
  kStageGarble,
  kStageSilent,
  kKill
};

const char* Name(Fault fault) {
  switch (fault) {
    case Fault::kPreviousFile:
      return "previous file";
    case Fault::kDisconnect:
      return "camera disconnect";
    case Fault::kCameraTimeout:
      return "camera timeout";
    case Fault::kStageGarble:
      return "stage garble";
    case Fault::kStageSilent:
      return "stage silent";
    case Fault::kKill:
      return "kill -9";
  }
  return "?";
}

bool IsStage(Fault fault) {
  return fault == Fault::kStageGarble || fault == Fault::kStageSilent;
}

// Which stage command a stage fault's burst hits: the "get pos" of the
// conditions' check at a frame boundary (the job suspends until the stage
// reads back), the "home" of a homing or the "move abs" of a move (the
// frame is taken again from its start, the stage homed first).
enum class Landing { kCheck, kHome, kMove };

const char* Name(Landing landing) {
  switch (landing) {
    case Landing::kCheck:
      return "check";
    case Landing::kHome:
      return "homing";
    case Landing::kMove:
      return "move";
  }
  return "?";
}

struct Planned {
  Fault fault;
  int frame;  // the sequence number of the frame it is aimed at
  Landing landing = Landing::kCheck;  // stage faults
  // A stage fault on the homing of the restarted daemon: its frame is the
  // first one the second run takes.
  bool at_restart = false;
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
// first or last few frames) and at least kGap frames apart, so that each
// fault is over before the next. Each stage fault is aimed at one of: a
// frame of its own (on the check), the change of view (on its move), the
// frame of the camera drop (on the re-homing after the suspension), the
// frame of the camera timeout (on the move that retakes it), the restart
// after the kill (on its homing); the two never at the same one.
std::vector<Planned> Draw(uint64_t seed, int total, int view_change) {
  constexpr int kGap = 12;
  constexpr int kTargets = 5;
  std::mt19937_64 rng(seed);
  auto frame = [&] { return 6 + static_cast<int>(rng() % (total - 14)); };
  // Drawn once, so that the frames' constraints do not favour the targets
  // that share a frame.
  const int garble_target = static_cast<int>(rng() % kTargets);
  int silent_target = static_cast<int>(rng() % kTargets);
  while (silent_target == garble_target && silent_target != 0) {
    silent_target = static_cast<int>(rng() % kTargets);
  }
  for (int attempt = 0; attempt < 100000; ++attempt) {
    std::vector<Planned> faults = {{Fault::kPreviousFile, frame()},
                                   {Fault::kDisconnect, frame()},
                                   {Fault::kCameraTimeout, frame()},
                                   {Fault::kKill, frame()}};
    // Frames that must be kGap apart: one per fault, but a stage fault
    // aimed at another fault's frame shares it.
    std::vector<int> anchors = {faults[0].frame, faults[1].frame,
                                faults[2].frame, faults[3].frame};
    for (const auto& [fault, target] :
         {std::pair{Fault::kStageGarble, garble_target},
          std::pair{Fault::kStageSilent, silent_target}}) {
      Planned p{fault, frame()};
      switch (target) {
        case 0:
          anchors.push_back(p.frame);
          break;
        case 1:
          p = {fault, view_change, Landing::kMove};
          anchors.push_back(p.frame);
          break;
        case 2:
          p = {fault, faults[1].frame, Landing::kHome};
          break;
        case 3:
          p = {fault, faults[2].frame, Landing::kMove};
          break;
        default:
          p = {fault, faults[3].frame, Landing::kHome, /*at_restart=*/true};
          break;
      }
      faults.push_back(p);
    }
    bool ok = true;
    for (size_t i = 0; i < anchors.size() && ok; ++i) {
      for (size_t j = i + 1; j < anchors.size() && ok; ++j) {
        ok = std::abs(anchors[i] - anchors[j]) >= kGap;
      }
    }
    if (ok) {
      // By frame; the kill before what happens at the restart.
      std::sort(faults.begin(), faults.end(),
                [](const Planned& a, const Planned& b) {
                  return std::pair{a.frame, a.at_restart} <
                         std::pair{b.frame, b.at_restart};
                });
      return faults;
    }
  }
  return {};
}

// The scene's fault triggers for one daemon run that starts the capture at
// frame `first` (the first frame not yet recorded), from a model of the
// commands the daemon sends: the simulator counts camera captures and stage
// commands from 1 in each run. `faults` are the camera and stage faults
// aimed at frames >= first that this run must fire; a stage fault whose
// landing the frame does not offer (its move moved by the kill) lands on
// the check instead, and `faults` says so.
//
// Stage, with the simulated time at 0 (every move ends by the first status
// poll): "get maxspeed" when the driver opens, the job's State() ("get
// pos", "warnings"); then, for every attempt at a frame, the conditions'
// State(), a Home() ("home", a poll) where the stage is to be homed (a new
// controller, after a suspension or a stage fault) and a MoveTo() (State(),
// "move abs", a poll) where it is to be placed (the run's first frame, the
// change of view, every retake). A burst on the check suspends the job
// (the State() that follows once the stage reads back is the next
// attempt's); one on a homing or a move fails that attempt. Camera: one
// capture per attempt that gets that far, one more for the previous file's
// retake.
nlohmann::json FaultsFor(int first, int view_change,
                         std::vector<Planned>& faults) {
  nlohmann::json camera = nlohmann::json::object();
  nlohmann::json stage = nlohmann::json::object();
  int command = 3;
  int call = 0;
  bool home = true;  // a new controller is not homed
  bool move = true;
  int last = first;
  for (const Planned& p : faults) last = std::max(last, p.frame);
  for (int frame = first; frame <= last; ++frame) {
    if (frame == view_change) move = true;
    Planned* camera_fault = nullptr;
    Planned* stage_fault = nullptr;
    for (Planned& p : faults) {
      if (p.frame != frame || p.fault == Fault::kKill) continue;
      (IsStage(p.fault) ? stage_fault : camera_fault) = &p;
    }
    if (stage_fault != nullptr) {
      const bool dropped =
          camera_fault != nullptr && camera_fault->fault == Fault::kDisconnect;
      const bool retaken =
          dropped || (camera_fault != nullptr &&
                      camera_fault->fault == Fault::kCameraTimeout);
      if ((stage_fault->landing == Landing::kHome && !home && !dropped) ||
          (stage_fault->landing == Landing::kMove && !home && !move &&
           !retaken)) {
        stage_fault->landing = Landing::kCheck;
      }
    }
    auto burst = [&](int start) {
      stage[stage_fault->fault == Fault::kStageGarble ? "garbled" : "silent"] =
          {{"calls", {start, start + 1, start + 2}}};
      stage_fault = nullptr;
    };
    for (bool taken = false; !taken;) {
      if (stage_fault != nullptr && stage_fault->landing == Landing::kCheck) {
        burst(command + 1);
        command += kBurst;
        home = move = true;
        continue;
      }
      command += 2;
      if (home) {
        if (stage_fault != nullptr && stage_fault->landing == Landing::kHome) {
          burst(command + 1);
          command += kBurst;
          move = true;
          continue;
        }
        command += 2;
        home = false;
        move = true;
      }
      if (move) {
        if (stage_fault != nullptr && stage_fault->landing == Landing::kMove) {
          burst(command + 3);
          command += 2 + kBurst;
          home = true;
          continue;
        }
        command += 4;
        move = false;
      }
      ++call;
      taken = true;
      if (camera_fault == nullptr) continue;
      switch (camera_fault->fault) {
        case Fault::kPreviousFile:
          camera["previous_file"] = {{"calls", {call}}};
          ++call;  // the retake
          break;
        case Fault::kDisconnect:
          camera["disconnect"] = {{"calls", {call}}};
          // The first reopen fails, the second (after the backoff) succeeds.
          camera["disconnect_failed_reopens"] = 1;
          home = move = true;
          taken = false;
          break;
        case Fault::kCameraTimeout:
          camera["timeout"] = {{"calls", {call}}};
          move = true;
          taken = false;
          break;
        default:
          break;
      }
      camera_fault = nullptr;
    }
  }
  return {{"camera", camera}, {"stage", stage}};
}

class ChaosTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  // Starts the daemon on the data root with a scene whose faults fire at
  // `faults` for a run that begins at frame `first` (FaultsFor: a stage
  // fault may land elsewhere than drawn).
  void StartRun(int run, int first, int view_change,
                std::vector<Planned>& faults) {
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

// What the stage fault's event says (an SQL LIKE pattern): on the check, the
// suspension; on a homing or a move, the warning that takes the frame again.
std::string StageEventPattern(const Planned& p) {
  const std::string reply = p.fault == Fault::kStageGarble
                                ? "answered \"%s\" with garbage"
                                : "did not answer \"%s\" within";
  switch (p.landing) {
    case Landing::kCheck:
      return absl::StrCat("suspended: the stage does not read back: stage on ",
                          "% ", absl::StrReplaceAll(reply, {{"%s", "get pos"}}),
                          "%");
    case Landing::kHome:
      return absl::StrCat("homing the stage: stage on % ",
                          absl::StrReplaceAll(reply, {{"%s", "home"}}),
                          "%; the stage is homed again and the frame is taken "
                          "again from its start (attempt % of at most 3)");
    case Landing::kMove:
      return absl::StrCat("moving the stage to % mm: stage on % ",
                          absl::StrReplaceAll(reply, {{"%s", "move abs %"}}),
                          "%; the stage is homed again and the frame is taken "
                          "again from its start (attempt % of at most 3)");
  }
  return "?";
}

TEST_F(ChaosTest, StructuredLightSurvivesEveryFaultAtRandomFrames) {
  const int total = PlannedFrames(/*views=*/2, /*exposures=*/2, 128, 96);
  const int view_change = total / 2;  // views are taken one after the other
  const std::vector<Planned> plan = Draw(seed_, total, view_change);
  ASSERT_EQ(plan.size(), 6u) << "no frames for the faults";
  auto describe = [](const std::vector<Planned>& faults) {
    std::string text;
    for (const Planned& p : faults) {
      absl::StrAppend(
          &text, text.empty() ? "" : ", ", Name(p.fault),
          p.at_restart ? " at the restart" : " at frame ",
          p.at_restart ? "" : absl::StrCat(p.frame),
          IsStage(p.fault) ? absl::StrCat(" (", Name(p.landing), ")") : "");
    }
    return text;
  };
  const std::string drawn = describe(plan);
  std::cout << "chaos seed " << seed_ << " (HDRSTEREO_CHAOS_SEED=" << seed_
            << " reproduces it): " << drawn << std::endl;
  RecordProperty("chaos_seed", std::to_string(seed_));
  RecordProperty("chaos_frames", drawn);
  const auto kill = std::find_if(plan.begin(), plan.end(), [](const auto& p) {
    return p.fault == Fault::kKill;
  });
  std::vector<Planned> before(plan.begin(), kill);
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
    p.frame = p.at_restart ? static_cast<int>(recorded)
                           : std::max(p.frame, static_cast<int>(recorded) + 2);
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
  // should be: a stage fault on the check suspends the job, one on a
  // homing or a move takes its frame again, as does a camera timeout.
  std::vector<Planned> fired = before;
  fired.insert(fired.end(), after.begin(), after.end());
  int stage_checks = 0;
  int stage_retakes = 0;
  for (const Planned& p : fired) {
    if (!IsStage(p.fault)) continue;
    (p.landing == Landing::kCheck ? stage_checks : stage_retakes) += 1;
    EXPECT_EQ(EventsLike(StageEventPattern(p)), 1) << StageEventPattern(p);
    // Counted as a device error where it took a frame again.
    EXPECT_EQ(EventsOfKind(p.fault == Fault::kStageGarble ? "stage_garbled"
                                                          : "stage_silent"),
              p.landing == Landing::kCheck ? 0 : 1)
        << Name(p.fault);
  }
  const int64_t previous = EventsLike("already taken in this capture");
  // Through libgphoto2 (HDRSTEREO_TEST_SIM_CAMERA=ptpip) the drop is the
  // network camera closing its connection, and a capture whose file never
  // comes leaves libgphoto2 waiting (docs/ptpip.md): the driver's deadline
  // marks the camera stuck, which is a second drop, not a retake.
  const bool ptpip = testing::TestsThroughPtpIp();
  const int64_t drops =
      EventsLike(ptpip ? "the camera dropped (%closed the connection "
                         "(disconnected)"
                       : "the camera dropped (camera disconnected");
  const int64_t timeouts = EventsLike(
      ptpip ? "the camera dropped (%no answer from the camera within"
            : "capturing: camera timed out (simulated fault, call %); the "
              "frame is taken again from its start (attempt 2 of at most 3)");
  const int camera_drops = ptpip ? 2 : 1;
  const int64_t camera_suspensions =
      EventsLike("suspended: camera disconnected");
  const int64_t stage_suspensions =
      EventsLike("suspended: the stage does not read back: ");
  const int64_t suspensions = EventsLike("suspended: ");
  const int64_t resumptions = EventsLike("resumed: the condition cleared");
  const int64_t interruptions =
      Count(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ", job,
                         " AND state = 'interrupted'"));
  const int64_t retakes =
      EventsLike("taking it again") + EventsLike("the frame is taken again");
  EXPECT_EQ(previous, 1);
  EXPECT_EQ(drops, 1);
  EXPECT_EQ(timeouts, 1);
  EXPECT_EQ(camera_suspensions, camera_drops);
  EXPECT_EQ(stage_suspensions, stage_checks);
  EXPECT_EQ(suspensions, camera_drops + stage_checks);
  EXPECT_EQ(resumptions, camera_drops + stage_checks);
  EXPECT_EQ(interruptions, 1);
  // The previous file, the drop, the timeout and the stage faults on moves.
  EXPECT_EQ(retakes, 3 + stage_retakes);
  EXPECT_EQ(EventsOfKind("previous_file"), 1);
  EXPECT_EQ(EventsOfKind("camera_disconnected"), camera_drops);
  EXPECT_EQ(EventsOfKind("camera_timeout"), ptpip ? 0 : 1);
  // The restarted daemon took up exactly the frames not yet recorded (its
  // progress event; a warning at its first frame carries the step too).
  EXPECT_EQ(Count(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id "
                               "= ",
                               job, " AND message = '' AND step = 'resuming: ",
                               recorded, " frames already recorded'")),
            1);
  EXPECT_EQ(Count("SELECT count(*) FROM job_events WHERE level = 'error'"), 0);
  // The camera is back and the rig idle.
  const nlohmann::json status = CliJson({"hw", "status"});
  EXPECT_EQ(status["camera"]["state"], "DEVICE_STATE_CONNECTED");
  EXPECT_EQ(status["stage"]["state"], "DEVICE_STATE_CONNECTED");

  // Where each fault fired: the frames recorded when its event was.
  const std::string figures = absl::StrFormat(
      "seed %d: %d/%d frames; %s; previous file after %d frames, camera drop "
      "after %d, camera timeout after %d, stage garble after %d, stage "
      "silent after %d, kill -9 after %d (%d restart); %d retakes, %d "
      "suspensions, %d resumptions; %.1f s",
      seed_, Count("SELECT count(*) FROM frames"), total, describe(fired),
      FrameOfEvent("%already taken in this capture%"),
      FrameOfEvent("%the camera dropped%"),
      FrameOfEvent("%camera timed out (simulated%"),
      FrameOfEvent("%with garbage%"), FrameOfEvent("%did not answer%"),
      recorded, interruptions, retakes, suspensions, resumptions,
      absl::ToDoubleSeconds(run_time));
  std::cout << "chaos figures: " << figures << std::endl;
  RecordProperty("chaos_figures", figures);
}

}  // namespace
}  // namespace hdrstereo
