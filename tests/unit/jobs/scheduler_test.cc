// SPDX-License-Identifier: GPL-3.0-or-later
//
// The scheduler against a real store with a fake clock: capture jobs are
// recorded (not run) and finished by the test, so a week takes about a
// second.
#include "daemon/jobs/scheduler.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "daemon/store/job_repository.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::jobs {
namespace {

using ::hdrstereo::testing::TempDir;
using ::testing::HasSubstr;

absl::Time Utc(const std::string& text) {
  absl::Time t;
  std::string error;
  EXPECT_TRUE(absl::ParseTime("%Y-%m-%d %H:%M", text, &t, &error)) << error;
  return t;
}

std::string Fmt(int64_t ms) {
  return absl::FormatTime("%Y-%m-%d %H:%M", absl::FromUnixMillis(ms),
                          absl::UTCTimeZone());
}

store::JobFilter QueuedFilter() {
  store::JobFilter filter;
  filter.states = {store::JobState::kQueued};
  filter.limit = 1000;
  return filter;
}

class SchedulerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    absl::StatusOr<std::unique_ptr<store::Store>> store =
        store::Store::Open(dir_ / "data");
    ASSERT_TRUE(store.ok()) << store.status();
    store_ = *std::move(store);
    jobs_ = std::make_unique<store::JobRepository>(*store_);
  }

  std::unique_ptr<Scheduler> NewScheduler() {
    SchedulerOptions options;
    options.clock = [this] { return now_; };
    options.hold = [this] { return hold_; };
    return std::make_unique<Scheduler>(
        *store_,
        [this](absl::string_view session, const v1::CapturePlan& plan,
               absl::string_view by) -> absl::StatusOr<int64_t> {
          absl::StatusOr<store::JobRecord> job =
              jobs_->Create(store::JobKind::kCapture, session,
                            plan.SerializeAsString(), 1, "queued", by);
          if (!job.ok()) return job.status();
          return job->id;
        },
        [this](absl::string_view session, const std::vector<std::string>&,
               absl::string_view by) -> absl::StatusOr<int64_t> {
          absl::StatusOr<store::JobRecord> job = jobs_->Create(
              store::JobKind::kProcessing, session, "", 1, "queued", by);
          if (!job.ok()) return job.status();
          return job->id;
        },
        options);
  }

  void AddSchedule(
      Scheduler& scheduler, const std::string& name, const std::string& cron,
      const std::string& zone,
      store::MissedRunPolicy policy = store::MissedRunPolicy::kRunOnceOnStart,
      const std::vector<std::string>& processing_steps = {}) {
    v1::SchedulePlan plan;
    plan.set_session_pattern(name + "-{date}-{time}");
    plan.add_captures()->mutable_bracketed_stereo();
    for (const std::string& step : processing_steps) {
      plan.add_processing_steps(step);
    }
    store::ScheduleRecord record;
    record.name = name;
    record.cron = cron;
    record.time_zone = zone;
    record.plan = plan.SerializeAsString();
    record.missed_run_policy = policy;
    record.created_by = "carol";
    ASSERT_TRUE(
        scheduler.repository().Create(record, absl::ToUnixMillis(now_)).ok());
  }

  // Finishes every queued job as succeeded.
  void FinishJobs() {
    absl::StatusOr<std::vector<store::JobRecord>> queued =
        jobs_->List(QueuedFilter());
    ASSERT_TRUE(queued.ok());
    for (const store::JobRecord& job : *queued) {
      ASSERT_TRUE(
          jobs_->SetState(job.id, store::JobState::kRunning, "run").ok());
      ASSERT_TRUE(
          jobs_->SetState(job.id, store::JobState::kSucceeded, "done").ok());
    }
  }

  // Advances the clock minute by minute to `end`, ticking each minute and
  // (if `finish`) finishing the jobs a run started.
  void RunUntil(Scheduler& scheduler, absl::Time end, bool finish = true) {
    while (now_ < end) {
      now_ += absl::Minutes(1);
      ASSERT_TRUE(scheduler.Tick().ok());
      if (finish) FinishJobs();
    }
    ASSERT_TRUE(scheduler.Tick().ok());
  }

  std::vector<store::ScheduleRunRecord> Runs(Scheduler& scheduler,
                                             const std::string& name) {
    absl::StatusOr<std::vector<store::ScheduleRunRecord>> runs =
        scheduler.repository().Runs(name, 0, 1000);
    EXPECT_TRUE(runs.ok());
    std::vector<store::ScheduleRunRecord> out(runs->rbegin(), runs->rend());
    return out;  // oldest first
  }

  TempDir dir_;
  std::unique_ptr<store::Store> store_;
  std::unique_ptr<store::JobRepository> jobs_;
  absl::Time now_ = Utc("2026-03-23 12:00");  // Monday
  absl::Status hold_;  // what SchedulerOptions::hold returns
};

TEST_F(SchedulerTest, SimulatedWeekAcrossSpringForwardYieldsExactlyTheRuns) {
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  // 02:30 Berlin every day; weekdays at 18:00 UTC.
  AddSchedule(*scheduler, "nightly", "30 2 * * *", "Europe/Berlin");
  AddSchedule(*scheduler, "evening", "0 18 * * MON-FRI", "UTC");
  RunUntil(*scheduler, Utc("2026-03-30 12:00"));

  std::vector<std::string> due;
  for (const store::ScheduleRunRecord& run : Runs(*scheduler, "nightly")) {
    EXPECT_EQ(run.outcome, store::RunOutcome::kSucceeded) << run.reason;
    EXPECT_EQ(run.job_ids.size(), 1u);
    EXPECT_EQ(run.reason, "");
    due.push_back(Fmt(run.due_time_ms) + " " + run.session);
  }
  // CET (+1) until Sunday 29 March; that day 02:30 does not exist and runs
  // once at the transition (03:00 CEST = 01:00 UTC); then CEST (+2).
  EXPECT_THAT(
      due, ::testing::ElementsAre("2026-03-24 01:30 nightly-2026-03-24-0230",
                                  "2026-03-25 01:30 nightly-2026-03-25-0230",
                                  "2026-03-26 01:30 nightly-2026-03-26-0230",
                                  "2026-03-27 01:30 nightly-2026-03-27-0230",
                                  "2026-03-28 01:30 nightly-2026-03-28-0230",
                                  "2026-03-29 01:00 nightly-2026-03-29-0300",
                                  "2026-03-30 00:30 nightly-2026-03-30-0230"));
  std::vector<std::string> evening;
  for (const store::ScheduleRunRecord& run : Runs(*scheduler, "evening")) {
    EXPECT_EQ(run.outcome, store::RunOutcome::kSucceeded);
    evening.push_back(Fmt(run.due_time_ms));
  }
  EXPECT_THAT(evening,
              ::testing::ElementsAre("2026-03-23 18:00", "2026-03-24 18:00",
                                     "2026-03-25 18:00", "2026-03-26 18:00",
                                     "2026-03-27 18:00"));
  // Each run's session exists with its job.
  absl::StatusOr<std::vector<store::JobRecord>> all =
      jobs_->List(store::JobFilter{});
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->size(), 12u);
}

TEST_F(SchedulerTest, RunStillGoingWhenTheNextIsDueIsSkippedWithReason) {
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  AddSchedule(*scheduler, "hourly", "0 * * * *", "UTC");
  RunUntil(*scheduler, Utc("2026-03-23 14:30"), /*finish=*/false);
  std::vector<store::ScheduleRunRecord> runs = Runs(*scheduler, "hourly");
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(Fmt(runs[0].due_time_ms), "2026-03-23 13:00");
  EXPECT_EQ(runs[0].outcome, store::RunOutcome::kRunning);
  EXPECT_EQ(Fmt(runs[1].due_time_ms), "2026-03-23 14:00");
  EXPECT_EQ(runs[1].outcome, store::RunOutcome::kSkipped);
  EXPECT_THAT(runs[1].reason,
              HasSubstr("session hourly-2026-03-23-1300) was still running"));
  // Once the job is done the next due time runs again.
  FinishJobs();
  RunUntil(*scheduler, Utc("2026-03-23 15:30"));
  runs = Runs(*scheduler, "hourly");
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runs[0].outcome, store::RunOutcome::kSucceeded);
  EXPECT_EQ(runs[2].outcome, store::RunOutcome::kSucceeded);
}

TEST_F(SchedulerTest, FailedJobFailsTheRun) {
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  AddSchedule(*scheduler, "once", "0 13 * * *", "UTC");
  RunUntil(*scheduler, Utc("2026-03-23 13:05"), /*finish=*/false);
  std::vector<store::ScheduleRunRecord> runs = Runs(*scheduler, "once");
  ASSERT_EQ(runs.size(), 1u);
  ASSERT_EQ(runs[0].job_ids.size(), 1u);
  ASSERT_TRUE(jobs_
                  ->SetState(runs[0].job_ids[0], store::JobState::kFailed,
                             "failed", "camera disconnected")
                  .ok());
  ASSERT_TRUE(scheduler->Tick().ok());
  runs = Runs(*scheduler, "once");
  EXPECT_EQ(runs[0].outcome, store::RunOutcome::kFailed);
  EXPECT_THAT(runs[0].reason, HasSubstr("camera disconnected"));
}

TEST_F(SchedulerTest, ProcessingStepsQueueAProcessingJobAfterTheCaptures) {
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  AddSchedule(*scheduler, "processed", "0 13 * * *", "UTC",
              store::MissedRunPolicy::kRunOnceOnStart, {"evaluate"});
  RunUntil(*scheduler, Utc("2026-03-23 13:05"), /*finish=*/false);
  std::vector<store::ScheduleRunRecord> runs = Runs(*scheduler, "processed");
  ASSERT_EQ(runs.size(), 1u);
  ASSERT_EQ(runs[0].job_ids.size(), 2u);
  absl::StatusOr<store::JobRecord> capture = jobs_->Get(runs[0].job_ids[0]);
  absl::StatusOr<store::JobRecord> processing = jobs_->Get(runs[0].job_ids[1]);
  ASSERT_TRUE(capture.ok() && processing.ok());
  EXPECT_EQ(capture->kind, store::JobKind::kCapture);
  EXPECT_EQ(processing->kind, store::JobKind::kProcessing);
  EXPECT_EQ(processing->session, runs[0].session);
  // The run lasts until the processing job ends too.
  ASSERT_TRUE(
      jobs_->SetState(capture->id, store::JobState::kRunning, "run").ok());
  ASSERT_TRUE(
      jobs_->SetState(capture->id, store::JobState::kSucceeded, "done").ok());
  ASSERT_TRUE(scheduler->Tick().ok());
  EXPECT_EQ(Runs(*scheduler, "processed")[0].outcome,
            store::RunOutcome::kRunning);
  FinishJobs();
  ASSERT_TRUE(scheduler->Tick().ok());
  EXPECT_EQ(Runs(*scheduler, "processed")[0].outcome,
            store::RunOutcome::kSucceeded);
}

TEST_F(SchedulerTest, InterruptedJobNotResumedEndsTheRun) {
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  AddSchedule(*scheduler, "hourly", "0 * * * *", "UTC");
  RunUntil(*scheduler, Utc("2026-03-23 13:05"), /*finish=*/false);
  std::vector<store::ScheduleRunRecord> runs = Runs(*scheduler, "hourly");
  ASSERT_EQ(runs.size(), 1u);
  const int64_t job = runs[0].job_ids.at(0);
  ASSERT_TRUE(jobs_->SetState(job, store::JobState::kRunning, "run").ok());
  ASSERT_TRUE(
      jobs_->SetState(job, store::JobState::kInterrupted, "stopped").ok());
  RunUntil(*scheduler, Utc("2026-03-23 14:05"));
  runs = Runs(*scheduler, "hourly");
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].outcome, store::RunOutcome::kFailed);
  EXPECT_THAT(runs[0].reason, HasSubstr("interrupted"));
  EXPECT_EQ(runs[1].outcome, store::RunOutcome::kSucceeded);
}

TEST_F(SchedulerTest, SessionNameTakenFailsTheRunWithReason) {
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  v1::SchedulePlan plan;
  plan.set_session_pattern("fixed");
  plan.add_captures()->mutable_bracketed_stereo();
  store::ScheduleRecord record;
  record.name = "fixed";
  record.cron = "0 * * * *";
  record.plan = plan.SerializeAsString();
  ASSERT_TRUE(
      scheduler->repository().Create(record, absl::ToUnixMillis(now_)).ok());
  RunUntil(*scheduler, Utc("2026-03-23 14:30"));
  std::vector<store::ScheduleRunRecord> runs = Runs(*scheduler, "fixed");
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].outcome, store::RunOutcome::kSucceeded);
  EXPECT_EQ(runs[1].outcome, store::RunOutcome::kFailed);
  EXPECT_THAT(runs[1].reason, HasSubstr("already exists"));
}

struct RestartCase {
  store::MissedRunPolicy policy;
  absl::Duration down_after_due;
  store::RunOutcome expected;
  const char* reason;
};

class RestartTest : public SchedulerTest,
                    public ::testing::WithParamInterface<RestartCase> {};

TEST_P(RestartTest, RestartAcrossADueTimeFollowsThePolicy) {
  const RestartCase& c = GetParam();
  {
    std::unique_ptr<Scheduler> scheduler = NewScheduler();
    AddSchedule(*scheduler, "nightly", "0 2 * * *", "UTC", c.policy);
    RunUntil(*scheduler, Utc("2026-03-24 01:00"));  // then the daemon stops
  }
  // The daemon was down across 02:00 and starts again later.
  now_ = Utc("2026-03-24 02:00") + c.down_after_due;
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  ASSERT_TRUE(scheduler->Tick().ok());
  std::vector<store::ScheduleRunRecord> runs = Runs(*scheduler, "nightly");
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(Fmt(runs[0].due_time_ms), "2026-03-24 02:00");
  EXPECT_EQ(runs[0].outcome, c.expected);
  EXPECT_THAT(runs[0].reason, HasSubstr(c.reason));
  EXPECT_EQ(runs[0].job_ids.empty(), c.expected == store::RunOutcome::kSkipped);
  // Exactly once: further passes do not run it again, and the next night
  // runs on time.
  FinishJobs();
  RunUntil(*scheduler, Utc("2026-03-25 03:00"));
  runs = Runs(*scheduler, "nightly");
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(Fmt(runs[1].due_time_ms), "2026-03-25 02:00");
  EXPECT_EQ(runs[1].outcome, store::RunOutcome::kSucceeded);
}

INSTANTIATE_TEST_SUITE_P(
    Policies, RestartTest,
    ::testing::Values(RestartCase{store::MissedRunPolicy::kRunOnceOnStart,
                                  absl::Hours(3), store::RunOutcome::kRunning,
                                  "started late: missed by 3 h 0 min"},
                      RestartCase{store::MissedRunPolicy::kRunOnceOnStart,
                                  absl::Hours(13), store::RunOutcome::kSkipped,
                                  "more than 12 h"},
                      RestartCase{store::MissedRunPolicy::kSkip, absl::Hours(3),
                                  store::RunOutcome::kSkipped, "policy skip"}));

TEST_F(SchedulerTest, DueTimesWhileDisabledDoNotRun) {
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  AddSchedule(*scheduler, "nightly", "0 2 * * *", "UTC");
  ASSERT_TRUE(
      scheduler->repository()
          .SetEnabled("nightly", false, absl::ToUnixMillis(now_), "dave")
          .ok());
  RunUntil(*scheduler, Utc("2026-03-25 12:00"));
  EXPECT_TRUE(Runs(*scheduler, "nightly").empty());
  ASSERT_TRUE(scheduler->repository()
                  .SetEnabled("nightly", true, absl::ToUnixMillis(now_), "erin")
                  .ok());
  RunUntil(*scheduler, Utc("2026-03-26 12:00"));
  std::vector<store::ScheduleRunRecord> runs = Runs(*scheduler, "nightly");
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(Fmt(runs[0].due_time_ms), "2026-03-26 02:00");
  // The run, and its job, are on behalf of whoever enabled it last.
  EXPECT_EQ(runs[0].caused_by, "erin");
  ASSERT_EQ(runs[0].job_ids.size(), 1u);
  absl::StatusOr<store::JobRecord> job = jobs_->Get(runs[0].job_ids[0]);
  ASSERT_TRUE(job.ok()) << job.status();
  EXPECT_EQ(job->submitted_by, "erin");
}

TEST_F(SchedulerTest, DueTimesWhileHeldAreSkippedWithTheHoldsReason) {
  std::unique_ptr<Scheduler> scheduler = NewScheduler();
  AddSchedule(*scheduler, "nightly", "0 2 * * *", "UTC");
  hold_ = absl::FailedPreconditionError(
      "locked by bob until 14:05: re-aligning the projector");
  RunUntil(*scheduler, Utc("2026-03-24 03:00"));
  hold_ = absl::OkStatus();
  RunUntil(*scheduler, Utc("2026-03-25 03:00"));
  std::vector<store::ScheduleRunRecord> runs = Runs(*scheduler, "nightly");
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(Fmt(runs[0].due_time_ms), "2026-03-24 02:00");
  EXPECT_EQ(runs[0].outcome, store::RunOutcome::kSkipped);
  EXPECT_EQ(runs[0].reason,
            "locked by bob until 14:05: re-aligning the projector");
  EXPECT_TRUE(runs[0].job_ids.empty());
  EXPECT_EQ(runs[0].caused_by, "carol");
  // Released: the next night runs, for the schedule's creator.
  EXPECT_EQ(runs[1].outcome, store::RunOutcome::kSucceeded);
  EXPECT_EQ(runs[1].caused_by, "carol");
}

TEST(SessionPatternTest, ExpandsInTheZoneAndRefusesBadPatterns) {
  absl::TimeZone berlin = *LoadZone("Europe/Berlin");
  absl::StatusOr<std::string> name = ExpandSessionPattern(
      "nightly-{date}", "n", Utc("2026-11-23 23:30"), berlin);
  ASSERT_TRUE(name.ok());
  EXPECT_EQ(*name, "nightly-2026-11-24");
  EXPECT_EQ(*ExpandSessionPattern("", "n", Utc("2026-11-23 23:30"),
                                  absl::UTCTimeZone()),
            "n-2026-11-23-2330");
  absl::StatusOr<std::string> bad =
      ExpandSessionPattern("x-{year}", "n", Utc("2026-11-23 23:30"), berlin);
  EXPECT_THAT(std::string(bad.status().message()), HasSubstr("{year}"));
  EXPECT_FALSE(
      ExpandSessionPattern("a/b-{date}", "n", Utc("2026-11-23 23:30"), berlin)
          .ok());
}

}  // namespace
}  // namespace hdrstereo::jobs
