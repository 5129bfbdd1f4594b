// SPDX-License-Identifier: GPL-3.0-or-later
//
// The scheduler: at each due time of an enabled schedule it creates the
// session named by the plan's pattern and submits the plan's captures, and
// records the run (schedule_runs). Its clock is injectable, so tests run
// days of schedule in milliseconds.
//
// Rules:
//  - Due times come from CronSchedule (see cron.h for the DST rule). Due
//    times before a schedule was created or (re)enabled never run.
//  - A due time is on time when the scheduler sees it within `on_time_slack`.
//    Later than that it was missed (hdrstereod was down or stalled): policy
//    `skip` records it as skipped; `run-once-on-start` (the default) runs it
//    once if it is less than `max_lateness` (12 h) late, else records it as
//    skipped. Of several due times missed in a row only the newest is
//    recorded (its reason counts the others).
//  - Never two runs of one schedule at once: a due time that comes while the
//    previous run's jobs are unfinished is recorded as skipped, with the
//    reason.
//  - A due time that comes while the rig is held (the rig lock, through
//    SchedulerOptions::hold) is recorded as skipped with the hold's reason.
//  - A run's jobs are submitted on behalf of the principal that created or
//    last enabled the schedule (recorded as the run's caused_by).
//  - A run is running until all its jobs are final (or interrupted and not
//    resumed), then succeeded (all succeeded) or failed (with the first
//    failure's reason).
#ifndef HDRSTEREO_DAEMON_JOBS_SCHEDULER_H_
#define HDRSTEREO_DAEMON_JOBS_SCHEDULER_H_

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <thread>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "daemon/jobs/capture_plan.h"
#include "daemon/jobs/cron.h"
#include "daemon/store/schedule_repository.h"
#include "hdrstereo/v1/schedules.pb.h"

namespace hdrstereo::jobs {

// Submits one capture job for `session` on behalf of `submitted_by`;
// returns its id.
using CaptureSubmitter = std::function<absl::StatusOr<int64_t>(
    absl::string_view session, const v1::CapturePlan& plan,
    absl::string_view submitted_by)>;

// Submits one processing job for `session` (steps as in
// SubmitProcessingRequest) on behalf of `submitted_by`; returns its id. The
// job waits for the captures submitted before it.
using ProcessingSubmitter = std::function<absl::StatusOr<int64_t>(
    absl::string_view session, const std::vector<std::string>& steps,
    absl::string_view submitted_by)>;

struct SchedulerOptions {
  std::function<absl::Time()> clock = [] { return absl::Now(); };
  absl::Duration tick = absl::Milliseconds(500);  // real time between passes
  absl::Duration on_time_slack = absl::Minutes(1);
  absl::Duration max_lateness = absl::Hours(12);
  // Non-OK while due runs must not start (the rig lock); its message is the
  // skipped run's reason. Unset = never held.
  std::function<absl::Status()> hold;
};

// The session name for a run due at `due`: "{date}" -> YYYY-MM-DD and
// "{time}" -> HHMM in `zone`; an empty pattern means "<schedule>-{date}-
// {time}". INVALID_ARGUMENT for other placeholders or an invalid name.
absl::StatusOr<std::string> ExpandSessionPattern(absl::string_view pattern,
                                                 absl::string_view schedule,
                                                 absl::Time due,
                                                 absl::TimeZone zone);

// Validates a schedule's plan at the edge: at least one capture, each
// normalisable on the rig (errors name plans.captures[i]), a valid pattern,
// and known processing steps.
absl::Status ValidateSchedulePlan(const v1::SchedulePlan& plan,
                                  absl::string_view schedule,
                                  const RigLimits& limits);

class Scheduler {
 public:
  // Without `submit_processing`, plans' processing steps are not run.
  Scheduler(store::Store& store, CaptureSubmitter submit,
            ProcessingSubmitter submit_processing,
            SchedulerOptions options = {});
  ~Scheduler();  // Stop()

  // Settles runs a previous process left running, then ticks on a thread.
  absl::Status Start() ABSL_LOCKS_EXCLUDED(tick_mutex_, mutex_);
  void Stop() ABSL_LOCKS_EXCLUDED(mutex_);

  // One pass at clock(): settles finished runs, then starts (or records as
  // skipped) every due time that has come. Public for tests.
  absl::Status Tick() ABSL_LOCKS_EXCLUDED(tick_mutex_);
  // Wakes the thread for a pass now (a schedule was added or enabled).
  void Wake() ABSL_LOCKS_EXCLUDED(mutex_);

  absl::Time Now() const { return options_.clock(); }
  // The next due time after now (and after the newest recorded run);
  // nullopt when disabled or never due.
  std::optional<absl::Time> NextDue(const store::ScheduleRecord& schedule);

  store::ScheduleRepository& repository() { return schedules_; }

 private:
  // The thread: a pass every options_.tick, or at Wake(), until Stop().
  void Loop() ABSL_LOCKS_EXCLUDED(mutex_);
  absl::Status SettleRunning() ABSL_EXCLUSIVE_LOCKS_REQUIRED(tick_mutex_);
  absl::Status HandleSchedule(const store::ScheduleRecord& schedule,
                              absl::Time now)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(tick_mutex_);
  absl::Status Launch(const store::ScheduleRecord& schedule,
                      const CronSchedule& cron, absl::Time due, absl::Time now,
                      std::string note)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(tick_mutex_);

  store::Store& store_;
  store::ScheduleRepository schedules_;
  CaptureSubmitter submit_;
  ProcessingSubmitter submit_processing_;
  const SchedulerOptions options_;

  absl::Mutex tick_mutex_;  // one pass at a time
  absl::Mutex mutex_;
  absl::CondVar cv_;
  bool stopping_ ABSL_GUARDED_BY(mutex_) = false;
  bool wake_ ABSL_GUARDED_BY(mutex_) = false;
  std::thread thread_;
};

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_SCHEDULER_H_
