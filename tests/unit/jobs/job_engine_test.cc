// SPDX-License-Identifier: GPL-3.0-or-later
//
// The job engine with a real SQLite store and runners that record what they
// did, so ordering, pause, cancel and restart behaviour are observable.
#include "daemon/jobs/job_engine.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <functional>

#include "absl/strings/str_cat.h"
#include "daemon/store/session_repository.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::jobs {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::TempDir;
using store::JobKind;
using store::JobState;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// Waits on the engine's own event signal until `done()` holds (generous
// bound; the engine's threads decide the timing, not the test). The
// generation is read before `done()`, so an event in between is not lost.
bool WaitUntil(JobEngine& engine, const std::function<bool()>& done) {
  const absl::Time deadline = absl::Now() + absl::Seconds(30);
  for (;;) {
    const int64_t generation = engine.event_generation();
    if (done()) return true;
    if (absl::Now() >= deadline) return false;
    engine.WaitForEvents(generation, deadline);
  }
}

// Every state change is an event.
bool WaitForState(JobEngine& engine, int64_t id, JobState state) {
  return WaitUntil(engine, [&] {
    absl::StatusOr<store::JobRecord> job = engine.repository().Get(id);
    return job.ok() && job->state == state;
  });
}

// What the job's record says of its suspension now.
std::string SuspensionReason(JobEngine& engine, int64_t id) {
  absl::StatusOr<store::JobRecord> job = engine.repository().Get(id);
  EXPECT_TRUE(job.ok()) << job.status();
  return job.ok() ? job->suspension_reason : "(no job)";
}

class JobEngineTest : public ::testing::Test {
 protected:
  void SetUp() override { OpenStore(); }

  void OpenStore() {
    absl::StatusOr<std::unique_ptr<store::Store>> s =
        store::Store::Open(dir_.path());
    ASSERT_TRUE(s.ok()) << s.status();
    store_ = *std::move(s);
    if (!store::SessionRepository(*store_).Get("s").ok()) {
      ASSERT_TRUE(store::SessionRepository(*store_).Create("s", "").ok());
    }
  }

  // A runner that does `steps` checkpointed steps, recording each.
  JobRunner StepRunner(int steps) {
    return [this, steps](JobContext& context) -> absl::Status {
      for (int i = 0; i < steps; ++i) {
        if (absl::Status s = context.Checkpoint(); !s.ok()) return s;
        {
          std::lock_guard<std::mutex> lock(log_mutex_);
          log_.push_back(context.job().id * 100 + i);
        }
        if (absl::Status s = context.Progress(i + 1, steps, "step"); !s.ok()) {
          return s;
        }
        while (hold_.load()) absl::SleepFor(absl::Milliseconds(1));
      }
      return absl::OkStatus();
    };
  }

  // A runner that does `steps` steps, each only while `Condition()` is clear
  // (JobContext::SuspendWhile, polled every 10 ms).
  JobRunner GuardedRunner(int steps) {
    return [this, steps](JobContext& context) -> absl::Status {
      for (int i = 0; i < steps; ++i) {
        if (absl::Status s = context.Checkpoint(); !s.ok()) return s;
        if (absl::Status s = context.SuspendWhile(
                [this] { return Condition(); }, absl::Milliseconds(10));
            !s.ok()) {
          return s;
        }
        {
          std::lock_guard<std::mutex> lock(log_mutex_);
          log_.push_back(context.job().id * 100 + i);
        }
        if (absl::Status s = context.Progress(i + 1, steps, "step"); !s.ok()) {
          return s;
        }
      }
      return absl::OkStatus();
    };
  }
  std::string Condition() {
    std::lock_guard<std::mutex> lock(log_mutex_);
    return condition_;
  }
  void SetCondition(const std::string& reason) {
    std::lock_guard<std::mutex> lock(log_mutex_);
    condition_ = reason;
  }
  // Messages of the job's events that contain `text`.
  int EventsWith(JobEngine& engine, int64_t id, const std::string& text) {
    absl::StatusOr<std::vector<store::JobEventRecord>> events =
        engine.repository().Events(id, 0);
    EXPECT_TRUE(events.ok());
    if (!events.ok()) return -1;
    int n = 0;
    for (const store::JobEventRecord& e : *events) {
      n += e.message.find(text) != std::string::npos;
    }
    return n;
  }

  std::vector<int64_t> Log() {
    std::lock_guard<std::mutex> lock(log_mutex_);
    return log_;
  }

  TempDir dir_;
  std::unique_ptr<store::Store> store_;
  std::mutex log_mutex_;
  std::vector<int64_t> log_;
  std::atomic<bool> hold_{false};
  std::string condition_;  // guarded by log_mutex_
};

TEST_F(JobEngineTest, CapturesRunOneAtATimeInSubmissionOrder) {
  JobEngine engine(*store_, StepRunner(3), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  std::vector<int64_t> ids;
  for (int i = 0; i < 3; ++i) {
    absl::StatusOr<store::JobRecord> job =
        engine.Submit(JobKind::kCapture, "s", "", 0, "test", "tester");
    ASSERT_TRUE(job.ok()) << job.status();
    EXPECT_EQ(job->submitted_by, "tester");
    ids.push_back(job->id);
  }
  for (int64_t id : ids) {
    ASSERT_TRUE(WaitForState(engine, id, JobState::kSucceeded));
  }
  // No interleaving: each job's three steps are contiguous, in order.
  EXPECT_THAT(Log(),
              ElementsAre(ids[0] * 100, ids[0] * 100 + 1, ids[0] * 100 + 2,
                          ids[1] * 100, ids[1] * 100 + 1, ids[1] * 100 + 2,
                          ids[2] * 100, ids[2] * 100 + 1, ids[2] * 100 + 2));
  absl::StatusOr<std::vector<store::JobEventRecord>> events =
      engine.repository().Events(ids[0], 0);
  ASSERT_TRUE(events.ok());
  // queued, running, 3 progress events, succeeded; sequences 1..6.
  ASSERT_EQ(events->size(), 6u);
  EXPECT_EQ(events->front().state, JobState::kQueued);
  EXPECT_EQ(events->back().state, JobState::kSucceeded);
  EXPECT_EQ(events->back().progress_done, 3);
  for (size_t i = 0; i < events->size(); ++i) {
    EXPECT_EQ((*events)[i].sequence, static_cast<int64_t>(i + 1));
  }
}

TEST_F(JobEngineTest, PauseWaitsAtTheNextCheckpointAndResumeContinues) {
  JobEngine engine(*store_, StepRunner(5), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  hold_ = true;
  absl::StatusOr<store::JobRecord> job =
      engine.Submit(JobKind::kCapture, "s", "", 0, "test", "tester");
  ASSERT_TRUE(job.ok());
  // Wait until the first step is done (logged before its progress event)
  // and the runner holds after it.
  ASSERT_TRUE(WaitUntil(engine, [&] { return !Log().empty(); }));
  ASSERT_TRUE(engine.Pause(job->id).ok());
  hold_ = false;
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kPaused));
  const size_t steps_when_paused = Log().size();
  EXPECT_EQ(steps_when_paused, 1u);
  EXPECT_EQ(engine.Pause(job->id).status().code(),
            absl::StatusCode::kFailedPrecondition);
  ASSERT_TRUE(engine.Resume(job->id).ok());
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kSucceeded));
  EXPECT_EQ(Log().size(), 5u);
  EXPECT_EQ(engine.Resume(job->id).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST_F(JobEngineTest, AConditionSuspendsAndItsClearingResumes) {
  JobEngine engine(*store_, GuardedRunner(3), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  SetCondition("the rig is unsafe");
  absl::StatusOr<store::JobRecord> job =
      engine.Submit(JobKind::kCapture, "s", "", 0, "test", "tester");
  ASSERT_TRUE(job.ok());
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kPaused));
  EXPECT_TRUE(Log().empty()) << "a step ran into the condition";
  EXPECT_EQ(EventsWith(engine, job->id, "suspended: the rig is unsafe"), 1);
  EXPECT_EQ(SuspensionReason(engine, job->id), "the rig is unsafe");
  // Nobody can resume into the condition.
  EXPECT_THAT(engine.Resume(job->id),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("suspended by a condition (the rig is "
                                 "unsafe); it resumes by itself")));
  // The record follows the condition's latest word, without a new event.
  SetCondition("the rig is still unsafe");
  ASSERT_TRUE(WaitUntil(engine, [&] {
    return SuspensionReason(engine, job->id) == "the rig is still unsafe";
  }));
  EXPECT_THAT(engine.Resume(job->id),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("(the rig is still unsafe)")));
  EXPECT_EQ(EventsWith(engine, job->id, "suspended: "), 1);
  SetCondition("");
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kSucceeded));
  EXPECT_EQ(Log().size(), 3u);
  EXPECT_EQ(EventsWith(engine, job->id,
                       "resumed: the condition cleared (was: the rig is "
                       "still unsafe)"),
            1);
  EXPECT_EQ(SuspensionReason(engine, job->id), "");
}

TEST_F(JobEngineTest, AnOperatorsPauseIsNeverAutoResumed) {
  JobEngine engine(*store_, GuardedRunner(2), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  SetCondition("the disk is full");
  absl::StatusOr<store::JobRecord> job =
      engine.Submit(JobKind::kCapture, "s", "", 0, "test", "tester");
  ASSERT_TRUE(job.ok());
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kPaused));
  ASSERT_TRUE(engine.Pause(job->id).ok());  // a person pauses it too
  SetCondition("");
  ASSERT_TRUE(WaitUntil(engine, [&] {
    return EventsWith(engine, job->id, "stays paused by the operator") == 1;
  }));
  absl::StatusOr<store::JobRecord> now = engine.repository().Get(job->id);
  ASSERT_TRUE(now.ok());
  EXPECT_EQ(now->state, JobState::kPaused);
  // Paused by the person now, not by the condition.
  EXPECT_EQ(now->suspension_reason, "");
  EXPECT_TRUE(Log().empty());
  EXPECT_EQ(EventsWith(engine, job->id, "resumed: the condition"), 0);
  ASSERT_TRUE(engine.Resume(job->id).ok());
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kSucceeded));
  EXPECT_EQ(Log().size(), 2u);
}

TEST_F(JobEngineTest, CancelAndShutdownWorkWhileSuspended) {
  JobEngine engine(*store_, GuardedRunner(2), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  SetCondition("the camera does not answer");
  absl::StatusOr<store::JobRecord> first =
      engine.Submit(JobKind::kCapture, "s", "", 0, "test", "tester");
  absl::StatusOr<store::JobRecord> second =
      engine.Submit(JobKind::kCapture, "s", "", 0, "test", "tester");
  ASSERT_TRUE(first.ok() && second.ok());
  ASSERT_TRUE(WaitForState(engine, first->id, JobState::kPaused));
  EXPECT_EQ(SuspensionReason(engine, first->id), "the camera does not answer");
  ASSERT_TRUE(engine.Cancel(first->id).ok());
  ASSERT_TRUE(WaitForState(engine, first->id, JobState::kCancelled));
  EXPECT_EQ(SuspensionReason(engine, first->id), "");
  // The next job starts into the same condition and is suspended too.
  ASSERT_TRUE(WaitForState(engine, second->id, JobState::kPaused));
  EXPECT_TRUE(Log().empty());
  engine.Shutdown();
  absl::StatusOr<store::JobRecord> stopped =
      engine.repository().Get(second->id);
  ASSERT_TRUE(stopped.ok());
  EXPECT_EQ(stopped->state, JobState::kInterrupted);
  EXPECT_EQ(stopped->suspension_reason, "");
}

TEST_F(JobEngineTest, CancelQueuedAndRunningJobs) {
  JobEngine engine(*store_, StepRunner(1000), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  hold_ = true;
  absl::StatusOr<store::JobRecord> running =
      engine.Submit(JobKind::kCapture, "s", "", 0, "first", "tester");
  absl::StatusOr<store::JobRecord> queued =
      engine.Submit(JobKind::kCapture, "s", "", 0, "second", "tester");
  ASSERT_TRUE(running.ok() && queued.ok());
  ASSERT_TRUE(WaitForState(engine, running->id, JobState::kRunning));
  ASSERT_TRUE(engine.Cancel(queued->id).ok());
  EXPECT_EQ(engine.repository().Get(queued->id)->state, JobState::kCancelled);
  ASSERT_TRUE(engine.Cancel(running->id).ok());
  hold_ = false;
  ASSERT_TRUE(WaitForState(engine, running->id, JobState::kCancelled));
  EXPECT_LT(Log().size(), 1000u);
  EXPECT_EQ(engine.Cancel(running->id).status().code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(engine.Cancel(12345).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(JobEngineTest, FailureKeepsTheMessage) {
  JobEngine engine(
      *store_,
      [](JobContext&) { return absl::UnavailableError("camera unplugged"); },
      StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  absl::StatusOr<store::JobRecord> job =
      engine.Submit(JobKind::kCapture, "s", "", 0, "test", "tester");
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kFailed));
  EXPECT_EQ(engine.repository().Get(job->id)->error, "camera unplugged");
  EXPECT_EQ(engine.Submit(JobKind::kCapture, "nope", "", 0, "x", "tester")
                .status()
                .code(),
            absl::StatusCode::kNotFound);
}

TEST_F(JobEngineTest, ShutdownInterruptsAndTheNextStartResumes) {
  int64_t id;
  {
    JobEngine engine(*store_, StepRunner(1000), StepRunner(1), {});
    ASSERT_TRUE(engine.Start().ok());
    hold_ = true;
    absl::StatusOr<store::JobRecord> job =
        engine.Submit(JobKind::kCapture, "s", "", 0, "long", "tester");
    ASSERT_TRUE(job.ok());
    id = job->id;
    ASSERT_TRUE(WaitForState(engine, id, JobState::kRunning));
    std::thread release([this] {
      absl::SleepFor(absl::Milliseconds(50));
      hold_ = false;
    });
    engine.Shutdown();
    release.join();
    EXPECT_EQ(engine.repository().Get(id)->state, JobState::kInterrupted);
  }
  // A crash leaves a job "running": simulate one too.
  {
    absl::MutexLock lock(&store_->db().mutex());
    ASSERT_TRUE(store_->db()
                    .Exec("INSERT INTO jobs (kind, session_id, state, request, "
                          "create_time_ms) SELECT 'capture', id, 'running', "
                          "x'', 0 FROM sessions")
                    .ok());
  }
  JobEngine engine(*store_, StepRunner(2), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  ASSERT_TRUE(WaitForState(engine, id, JobState::kSucceeded));
  ASSERT_TRUE(WaitForState(engine, id + 1, JobState::kSucceeded));
  absl::StatusOr<std::vector<store::JobEventRecord>> events =
      engine.repository().Events(id, 0);
  ASSERT_TRUE(events.ok());
  bool saw_interrupted = false;
  for (const auto& e : *events) {
    saw_interrupted |= e.state == JobState::kInterrupted;
  }
  EXPECT_TRUE(saw_interrupted);
}

// A runner that waits for the operator before each of `poses` steps, as a
// calibration capture does before each board pose.
JobRunner PoseRunner(int poses) {
  return [poses](JobContext& context) -> absl::Status {
    for (int i = context.job().progress_done; i < poses; ++i) {
      if (absl::Status s = context.WaitForOperator(
              absl::StrCat("place the board in pose ", i + 1, " of ", poses,
                           " and continue"));
          !s.ok()) {
        return s;
      }
      if (absl::Status s = context.Progress(i + 1, poses, "pose"); !s.ok()) {
        return s;
      }
    }
    return absl::OkStatus();
  };
}

TEST_F(JobEngineTest, AWaitingJobGoesOnWhenContinued) {
  JobEngine engine(*store_, PoseRunner(2), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  absl::StatusOr<store::JobRecord> job =
      engine.Submit(JobKind::kCapture, "s", "", 2, "calibration", "tester");
  ASSERT_TRUE(job.ok());
  // Not waiting yet (queued): refused, naming the state.
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kWaiting));
  absl::StatusOr<store::JobRecord> waiting = engine.repository().Get(job->id);
  ASSERT_TRUE(waiting.ok());
  EXPECT_EQ(waiting->instruction,
            "place the board in pose 1 of 2 and continue");
  // Listed as waiting, not as paused.
  absl::StatusOr<std::vector<store::JobRecord>> listed =
      engine.repository().List({.session = "", .states = {JobState::kWaiting}});
  ASSERT_TRUE(listed.ok());
  EXPECT_EQ(listed->size(), 1u);
  listed =
      engine.repository().List({.session = "", .states = {JobState::kPaused}});
  ASSERT_TRUE(listed.ok());
  EXPECT_TRUE(listed->empty());
  // A waiting job is not paused or resumed.
  EXPECT_THAT(
      engine.Pause(job->id).status(),
      StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("is waiting")));
  // Continue answers with the job as it goes on.
  absl::StatusOr<store::JobRecord> continued = engine.Continue(job->id);
  ASSERT_TRUE(continued.ok()) << continued.status();
  EXPECT_EQ(continued->state, JobState::kRunning);
  EXPECT_EQ(continued->instruction, "");
  ASSERT_TRUE(WaitUntil(engine, [&] {
    absl::StatusOr<store::JobRecord> j = engine.repository().Get(job->id);
    return j.ok() && j->state == JobState::kWaiting && j->progress_done == 1;
  }));
  EXPECT_EQ(engine.repository().Get(job->id)->instruction,
            "place the board in pose 2 of 2 and continue");
  ASSERT_TRUE(engine.Continue(job->id).ok());
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kSucceeded));
  EXPECT_EQ(engine.repository().Get(job->id)->instruction, "");
  EXPECT_THAT(engine.Continue(job->id).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("job " + std::to_string(job->id) +
                                 " is succeeded; only a waiting job can be "
                                 "continued")));
  EXPECT_EQ(EventsWith(engine, job->id, "waiting: place the board in pose"), 2);
  EXPECT_EQ(EventsWith(engine, job->id, "continued by the operator"), 2);
}

TEST_F(JobEngineTest, ARunningJobCannotBeContinued) {
  JobEngine engine(*store_, StepRunner(3), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  hold_ = true;
  absl::StatusOr<store::JobRecord> job =
      engine.Submit(JobKind::kCapture, "s", "", 0, "test", "tester");
  ASSERT_TRUE(job.ok());
  ASSERT_TRUE(WaitUntil(engine, [&] { return !Log().empty(); }));
  EXPECT_THAT(engine.Continue(job->id).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("is running; only a waiting job")));
  hold_ = false;
  ASSERT_TRUE(WaitForState(engine, job->id, JobState::kSucceeded));
}

TEST_F(JobEngineTest, AWaitingJobWaitsAgainAfterARestartAndCanBeCancelled) {
  int64_t id;
  {
    JobEngine engine(*store_, PoseRunner(3), StepRunner(1), {});
    ASSERT_TRUE(engine.Start().ok());
    absl::StatusOr<store::JobRecord> job =
        engine.Submit(JobKind::kCapture, "s", "", 3, "calibration", "tester");
    ASSERT_TRUE(job.ok());
    id = job->id;
    ASSERT_TRUE(WaitForState(engine, id, JobState::kWaiting));
    ASSERT_TRUE(engine.Continue(id).ok());
    ASSERT_TRUE(WaitUntil(engine, [&] {
      absl::StatusOr<store::JobRecord> j = engine.repository().Get(id);
      return j.ok() && j->state == JobState::kWaiting && j->progress_done == 1;
    }));
    engine.Shutdown();
    EXPECT_EQ(engine.repository().Get(id)->state, JobState::kInterrupted);
  }
  JobEngine engine(*store_, PoseRunner(3), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  ASSERT_TRUE(WaitForState(engine, id, JobState::kWaiting));
  EXPECT_EQ(engine.repository().Get(id)->instruction,
            "place the board in pose 2 of 3 and continue");
  ASSERT_TRUE(engine.Cancel(id).ok());
  ASSERT_TRUE(WaitForState(engine, id, JobState::kCancelled));
}

TEST_F(JobEngineTest, WaitForEventsWakesOnProgress) {
  JobEngine engine(*store_, StepRunner(1), StepRunner(1), {});
  ASSERT_TRUE(engine.Start().ok());
  const int64_t generation = engine.event_generation();
  ASSERT_TRUE(
      engine.Submit(JobKind::kProcessing, "s", "", 0, "p", "tester").ok());
  engine.WaitForEvents(generation, absl::Now() + absl::Seconds(30));
  EXPECT_NE(engine.event_generation(), generation);
}

}  // namespace
}  // namespace hdrstereo::jobs
