// SPDX-License-Identifier: GPL-3.0-or-later
//
// The job engine: a hardware lane that runs capture jobs one at a time in
// submission order, and a pool that runs processing jobs. Jobs live in
// SQLite (JobRepository); the engine only holds the queues and the flags
// that pause, cancel or stop a running job at its next checkpoint.
#ifndef HDRSTEREO_DAEMON_JOBS_JOB_ENGINE_H_
#define HDRSTEREO_DAEMON_JOBS_JOB_ENGINE_H_

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "daemon/store/job_repository.h"

namespace hdrstereo::jobs {

class JobEngine;

// What a running job sees of the engine.
class JobContext {
 public:
  const store::JobRecord& job() const { return job_; }
  store::Store& store() { return store_; }

  // Call between frames or steps: blocks while the job is paused; returns
  // CANCELLED when it was cancelled and ABORTED when the daemon is stopping.
  // The job must then leave the hardware safe and return that status.
  absl::Status Checkpoint();

  // Call at frame boundaries with what must hold for the job to go on:
  // `condition` returns why the job cannot continue ("" when it can). While
  // it has a reason the job is paused with origin "condition" (event
  // "suspended: <reason>"; the job's suspension_reason holds the latest
  // reason until the suspension ends), `condition` is asked again every
  // `poll`, and once it clears the job resumes by itself (event "resumed:
  // ...") unless an operator paused it meanwhile (then it waits for their
  // Resume).
  // CANCELLED and ABORTED as for Checkpoint().
  absl::Status SuspendWhile(const std::function<std::string()>& condition,
                            absl::Duration poll);

  // Records progress (and its event). `also` runs first inside the same
  // transaction, e.g. to insert the frame row that this progress counts.
  absl::Status Progress(int64_t done, int64_t total, absl::string_view step,
                        const std::function<absl::Status()>& also = nullptr);
  // Record an event; `tag` says what the metrics count it as.
  void Warn(absl::string_view message, const store::EventTag& tag = {});
  void Info(absl::string_view message, const store::EventTag& tag = {});

 private:
  friend class JobEngine;
  JobContext(JobEngine& engine, store::Store& store, store::JobRecord job)
      : engine_(engine), store_(store), job_(std::move(job)) {}
  JobEngine& engine_;
  store::Store& store_;
  store::JobRecord job_;
};

// Runs one job to its end. Returning OK means succeeded; CANCELLED and
// ABORTED come from Checkpoint(); anything else fails the job with its
// message (and the event kind it was marked with, store::WithEventKind).
using JobRunner = std::function<absl::Status(JobContext& context)>;

struct JobEngineOptions {
  int processing_threads = 2;
  // Jobs found interrupted at start-up are queued again (they resume from
  // what is already recorded).
  bool resume_interrupted = true;
};

class JobEngine {
 public:
  JobEngine(store::Store& store, JobRunner capture_runner,
            JobRunner processing_runner, JobEngineOptions options);
  ~JobEngine();  // Shutdown()

  // Marks jobs a previous process left running as interrupted, queues the
  // queued (and, if configured, interrupted) ones, starts the threads.
  absl::Status Start() ABSL_LOCKS_EXCLUDED(mutex_);
  // Stops at the next checkpoint of every running job (which becomes
  // interrupted, to be resumed by the next Start()) and joins the threads.
  void Shutdown() ABSL_LOCKS_EXCLUDED(mutex_);

  // Queues a job submitted by the principal `submitted_by`.
  absl::StatusOr<store::JobRecord> Submit(
      store::JobKind kind, absl::string_view session, absl::string_view request,
      int64_t total, absl::string_view message, absl::string_view submitted_by);
  // Pause applies to running jobs and to ones a condition suspended (they
  // then stay paused once it clears); Resume to operator-paused ones; cancel
  // to queued, running and paused ones. FAILED_PRECONDITION for other
  // states, with the reason.
  absl::StatusOr<store::JobRecord> Pause(int64_t id);
  absl::StatusOr<store::JobRecord> Resume(int64_t id);
  absl::StatusOr<store::JobRecord> Cancel(int64_t id);

  // Blocks until any job records a new event or `deadline` passes; watchers
  // then read the new events from the store.
  void WaitForEvents(int64_t seen_generation, absl::Time deadline)
      ABSL_LOCKS_EXCLUDED(mutex_);
  int64_t event_generation() ABSL_LOCKS_EXCLUDED(mutex_);
  bool stopping() ABSL_LOCKS_EXCLUDED(mutex_);
  // The id of the capture job the hardware lane runs now (from when it
  // takes the job from the queue until the job has ended), or 0.
  int64_t running_capture() ABSL_LOCKS_EXCLUDED(mutex_);

  store::JobRepository& repository() { return jobs_; }
  store::Store& store() { return store_; }

 private:
  friend class JobContext;
  struct Control {
    bool pause = false;  // by an operator
    bool cancel = false;
    // Suspended by a condition (its reason: the job's suspension_reason).
    bool suspended = false;
  };
  struct Lane {
    std::deque<int64_t> queue;
    std::vector<std::thread> threads;
  };

  void Enqueue(store::JobKind kind, int64_t id) ABSL_LOCKS_EXCLUDED(mutex_);
  void WorkerLoop(store::JobKind kind) ABSL_LOCKS_EXCLUDED(mutex_);
  void RunJob(int64_t id) ABSL_LOCKS_EXCLUDED(mutex_);
  void NotifyEvent() ABSL_LOCKS_EXCLUDED(mutex_);
  void NotifyEventLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  absl::Status CheckpointFor(int64_t id) ABSL_LOCKS_EXCLUDED(mutex_);
  absl::Status SuspendWhileFor(int64_t id,
                               const std::function<std::string()>& condition,
                               absl::Duration poll) ABSL_LOCKS_EXCLUDED(mutex_);

  store::Store& store_;
  store::JobRepository jobs_;
  JobRunner capture_runner_;
  JobRunner processing_runner_;
  const JobEngineOptions options_;

  absl::Mutex mutex_;
  absl::CondVar work_cv_;     // queues changed, or stopping
  absl::CondVar control_cv_;  // pause/resume/cancel/stop
  absl::CondVar event_cv_;    // a job event was recorded
  Lane capture_lane_ ABSL_GUARDED_BY(mutex_);
  Lane processing_lane_ ABSL_GUARDED_BY(mutex_);
  // Controls of running jobs.
  std::map<int64_t, Control> running_ ABSL_GUARDED_BY(mutex_);
  int64_t running_capture_ ABSL_GUARDED_BY(mutex_) = 0;
  int64_t event_generation_ ABSL_GUARDED_BY(mutex_) = 0;
  bool stopping_ ABSL_GUARDED_BY(mutex_) = false;
  bool started_ ABSL_GUARDED_BY(mutex_) = false;
};

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_JOB_ENGINE_H_
