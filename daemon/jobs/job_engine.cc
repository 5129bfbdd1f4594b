// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/job_engine.h"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::jobs {

using store::JobKind;
using store::JobRecord;
using store::JobState;

absl::Status JobContext::Checkpoint() { return engine_.CheckpointFor(job_.id); }

absl::Status JobContext::SuspendWhile(
    const std::function<std::string()>& condition, absl::Duration poll) {
  return engine_.SuspendWhileFor(job_.id, condition, poll);
}

absl::Status JobContext::WaitForOperator(absl::string_view instruction) {
  return engine_.WaitForOperatorFor(job_.id, instruction);
}

absl::Status JobContext::Progress(int64_t done, int64_t total,
                                  absl::string_view step,
                                  const std::function<absl::Status()>& also) {
  {
    store::Transaction tx(store_.db());
    RETURN_IF_ERROR(tx.status());
    if (also != nullptr) {
      RETURN_IF_ERROR(also());
    }
    RETURN_IF_ERROR(
        engine_.jobs_.SetProgressLocked(job_.id, done, total, step).status());
    RETURN_IF_ERROR(tx.Commit());
  }
  engine_.NotifyEvent();
  return absl::OkStatus();
}

void JobContext::Info(absl::string_view message, const store::EventTag& tag) {
  spdlog::info("job {} ({}): {}", job_.id, job_.session, std::string(message));
  engine_.jobs_.AddEvent(job_.id, store::EventLevel::kInfo, message, tag)
      .IgnoreError();
  engine_.NotifyEvent();
}

void JobContext::Warn(absl::string_view message, const store::EventTag& tag) {
  spdlog::warn("job {} ({}): {}", job_.id, job_.session, std::string(message));
  engine_.jobs_.AddEvent(job_.id, store::EventLevel::kWarning, message, tag)
      .IgnoreError();
  engine_.NotifyEvent();
}

JobEngine::JobEngine(store::Store& store, JobRunner capture_runner,
                     JobRunner processing_runner, JobEngineOptions options)
    : store_(store),
      jobs_(store),
      capture_runner_(std::move(capture_runner)),
      processing_runner_(std::move(processing_runner)),
      options_(options) {}

JobEngine::~JobEngine() { Shutdown(); }

absl::Status JobEngine::Start() {
  ASSIGN_OR_RETURN(std::vector<int64_t> interrupted,
                   jobs_.InterruptUnfinished());
  for (int64_t id : interrupted) {
    spdlog::warn("job {} was interrupted by a stop of the daemon", id);
  }
  std::vector<JobState> states = {JobState::kQueued};
  if (options_.resume_interrupted) states.push_back(JobState::kInterrupted);
  std::vector<JobRecord> pending;
  for (int64_t after = 0;;) {
    ASSIGN_OR_RETURN(std::vector<JobRecord> page, jobs_.List({.session = "",
                                                              .states = states,
                                                              .after_id = after,
                                                              .limit = 500}));
    if (page.empty()) break;
    after = page.back().id;
    pending.insert(pending.end(), page.begin(), page.end());
  }
  for (const JobRecord& job : pending) {
    if (job.state == JobState::kInterrupted) {
      RETURN_IF_ERROR(
          jobs_
              .SetState(
                  job.id, JobState::kQueued,
                  "queued again after a restart; resumes from what is recorded")
              .status());
      spdlog::info("job {} ({}): queued again to resume", job.id, job.session);
    }
    Enqueue(job.kind, job.id);
  }

  absl::MutexLock lock(&mutex_);
  started_ = true;
  capture_lane_.threads.emplace_back([this] { WorkerLoop(JobKind::kCapture); });
  for (int i = 0; i < std::max(1, options_.processing_threads); ++i) {
    processing_lane_.threads.emplace_back(
        [this] { WorkerLoop(JobKind::kProcessing); });
  }
  return absl::OkStatus();
}

void JobEngine::Shutdown() {
  std::vector<std::thread> threads;
  {
    absl::MutexLock lock(&mutex_);
    if (stopping_ && !started_) return;
    stopping_ = true;
    started_ = false;
    for (Lane* lane : {&capture_lane_, &processing_lane_}) {
      for (std::thread& t : lane->threads) threads.push_back(std::move(t));
      lane->threads.clear();
    }
  }
  work_cv_.SignalAll();
  control_cv_.SignalAll();
  event_cv_.SignalAll();
  for (std::thread& t : threads) t.join();
}

void JobEngine::Enqueue(JobKind kind, int64_t id) {
  absl::MutexLock lock(&mutex_);
  (kind == JobKind::kCapture ? capture_lane_ : processing_lane_)
      .queue.push_back(id);
  work_cv_.SignalAll();
}

absl::StatusOr<JobRecord> JobEngine::Submit(
    JobKind kind, absl::string_view session, absl::string_view request,
    int64_t total, absl::string_view message, absl::string_view submitted_by) {
  {
    absl::MutexLock lock(&mutex_);
    if (stopping_) return absl::UnavailableError("the daemon is stopping");
  }
  ASSIGN_OR_RETURN(JobRecord job, jobs_.Create(kind, session, request, total,
                                               message, submitted_by));
  spdlog::info("job {} ({}): queued by {}: {}", job.id, job.session,
               std::string(submitted_by), std::string(message));
  Enqueue(kind, job.id);
  NotifyEvent();
  return job;
}

void JobEngine::WorkerLoop(JobKind kind) {
  while (true) {
    int64_t id;
    {
      absl::MutexLock lock(&mutex_);
      std::deque<int64_t>& queue =
          (kind == JobKind::kCapture ? capture_lane_ : processing_lane_).queue;
      while (!stopping_ && queue.empty()) work_cv_.Wait(&mutex_);
      if (stopping_) return;
      id = queue.front();
      queue.pop_front();
      running_[id] = Control{};
      if (kind == JobKind::kCapture) running_capture_ = id;
    }
    RunJob(id);
    {
      absl::MutexLock lock(&mutex_);
      running_.erase(id);
      if (kind == JobKind::kCapture) running_capture_ = 0;
    }
  }
}

void JobEngine::RunJob(int64_t id) {
  absl::StatusOr<JobRecord> job = jobs_.Get(id);
  if (!job.ok()) {
    spdlog::error("job {}: cannot load: {}", id,
                  std::string(job.status().message()));
    return;
  }
  if (job->state != JobState::kQueued) return;  // cancelled meanwhile
  if (absl::StatusOr<store::JobEventRecord> e =
          jobs_.SetState(id, JobState::kRunning, "started");
      !e.ok()) {
    spdlog::error("job {}: {}", id, std::string(e.status().message()));
    return;
  }
  NotifyEvent();
  spdlog::info("job {} ({}): started", id, job->session);
  job->state = JobState::kRunning;

  JobContext context(*this, store_, *job);
  const JobRunner& runner =
      job->kind == JobKind::kCapture ? capture_runner_ : processing_runner_;
  absl::Status status = runner(context);

  const bool stopping = this->stopping();
  JobState final_state;
  std::string message;
  std::string error;
  store::EventTag tag;
  if (status.ok()) {
    final_state = JobState::kSucceeded;
    message = "succeeded";
  } else if (absl::IsCancelled(status)) {
    final_state = JobState::kCancelled;
    message = "cancelled";
  } else if (stopping) {
    final_state = JobState::kInterrupted;
    message =
        "interrupted: the daemon is stopping; it resumes at the next start";
  } else {
    final_state = JobState::kFailed;
    error = std::string(status.message());
    message = absl::StrCat("failed: ", error);
    tag.kind = store::EventKindOf(status);
  }
  absl::StatusOr<store::JobEventRecord> event =
      jobs_.SetState(id, final_state, message, error, tag);
  if (!event.ok()) {
    spdlog::error("job {}: cannot record its end: {}", id,
                  std::string(event.status().message()));
  }
  NotifyEvent();
  if (final_state == JobState::kFailed) {
    spdlog::error("job {} ({}): {}", id, job->session, message);
  } else {
    spdlog::info("job {} ({}): {}", id, job->session, message);
  }
}

absl::Status JobEngine::CheckpointFor(int64_t id) {
  absl::MutexLock lock(&mutex_);
  bool paused = false;
  while (true) {
    Control& control = running_[id];
    if (stopping_) return absl::AbortedError("the daemon is stopping");
    if (control.cancel) return absl::CancelledError("cancelled");
    if (!control.pause) break;
    if (!paused) {
      paused = true;
      jobs_.SetState(id, JobState::kPaused, "paused").IgnoreError();
      NotifyEventLocked();
    }
    control_cv_.Wait(&mutex_);
  }
  if (paused) {
    jobs_.SetState(id, JobState::kRunning, "resumed").IgnoreError();
    NotifyEventLocked();
  }
  return absl::OkStatus();
}

absl::Status JobEngine::WaitForOperatorFor(int64_t id,
                                           absl::string_view instruction) {
  absl::MutexLock lock(&mutex_);
  Control& control = running_[id];
  control.waiting = true;
  control.continued = false;
  spdlog::info("job {}: waiting: {}", id, std::string(instruction));
  absl::Status recorded = jobs_.Wait(id, instruction).status();
  NotifyEventLocked();
  absl::Status result = absl::OkStatus();
  if (!recorded.ok()) {
    result = recorded;
  } else {
    while (true) {
      if (stopping_) {
        result = absl::AbortedError("the daemon is stopping");
        break;
      }
      if (control.cancel) {
        result = absl::CancelledError("cancelled");
        break;
      }
      if (control.continued) break;
      control_cv_.Wait(&mutex_);
    }
  }
  control.waiting = false;
  control.continued = false;
  return result;  // Continue recorded the state
}

absl::Status JobEngine::SuspendWhileFor(
    int64_t id, const std::function<std::string()>& condition,
    absl::Duration poll) {
  std::string reason = condition();
  std::string recorded;  // the reason the job's record holds
  while (!reason.empty()) {
    {
      absl::MutexLock lock(&mutex_);
      Control& control = running_[id];
      if (!control.suspended) {
        spdlog::warn("job {}: suspended: {}", id, reason);
        jobs_.Suspend(id, reason).IgnoreError();
        NotifyEventLocked();
      } else if (reason != recorded) {
        jobs_.UpdateSuspensionReason(id, reason).IgnoreError();
        NotifyEventLocked();
      }
      control.suspended = true;
      recorded = reason;
      if (stopping_) return absl::AbortedError("the daemon is stopping");
      if (control.cancel) return absl::CancelledError("cancelled");
      control_cv_.WaitWithTimeout(&mutex_, poll);
      if (stopping_) return absl::AbortedError("the daemon is stopping");
      if (control.cancel) return absl::CancelledError("cancelled");
    }
    // The condition is asked without the lock: it talks to devices.
    const std::string now = condition();
    if (!now.empty()) {
      reason = now;
      continue;
    }
    {
      absl::MutexLock lock(&mutex_);
      Control& cleared = running_[id];
      cleared.suspended = false;
      if (!cleared.pause) {
        spdlog::info("job {}: resumed: the condition cleared (was: {})", id,
                     reason);
        jobs_
            .SetState(id, JobState::kRunning,
                      absl::StrCat(
                          "resumed: the condition cleared (was: ", reason, ")"))
            .IgnoreError();
        NotifyEventLocked();
        return absl::OkStatus();
      }
      // The operator's pause outlasts the condition: never auto-resumed.
      jobs_
          .EndSuspension(id, absl::StrCat("condition cleared (was: ", reason,
                                          "); stays paused by the operator"))
          .IgnoreError();
      NotifyEventLocked();
    }
    RETURN_IF_ERROR(CheckpointFor(id));
    reason = condition();  // it may have come back meanwhile
  }
  return absl::OkStatus();
}

absl::StatusOr<JobRecord> JobEngine::Pause(int64_t id) {
  ASSIGN_OR_RETURN(JobRecord job, jobs_.Get(id));
  {
    absl::MutexLock lock(&mutex_);
    auto it = running_.find(id);
    const bool suspended = it != running_.end() && it->second.suspended;
    if (it == running_.end() ||
        (job.state != JobState::kRunning && !suspended)) {
      return absl::FailedPreconditionError(
          absl::StrCat("job ", id, " is ", store::JobStateName(job.state),
                       "; only a running job can be paused"));
    }
    it->second.pause = true;
  }
  control_cv_.SignalAll();
  return job;
}

absl::StatusOr<JobRecord> JobEngine::Resume(int64_t id) {
  ASSIGN_OR_RETURN(JobRecord job, jobs_.Get(id));
  {
    absl::MutexLock lock(&mutex_);
    auto it = running_.find(id);
    if (it != running_.end() && !it->second.pause && it->second.suspended) {
      // Read again under the lock: the reason the record holds now.
      ASSIGN_OR_RETURN(JobRecord suspended, jobs_.Get(id));
      return absl::FailedPreconditionError(
          absl::StrCat("job ", id, " is suspended by a condition (",
                       suspended.suspension_reason,
                       "); it resumes by itself when that clears"));
    }
    if (it == running_.end() || !it->second.pause) {
      return absl::FailedPreconditionError(
          absl::StrCat("job ", id, " is ", store::JobStateName(job.state),
                       "; only a paused job can be resumed"));
    }
    it->second.pause = false;
  }
  control_cv_.SignalAll();
  return jobs_.Get(id);
}

absl::StatusOr<JobRecord> JobEngine::Cancel(int64_t id) {
  ASSIGN_OR_RETURN(JobRecord job, jobs_.Get(id));
  if (store::IsFinal(job.state)) {
    return absl::FailedPreconditionError(absl::StrCat(
        "job ", id, " is already ", store::JobStateName(job.state)));
  }
  bool was_queued = false;
  {
    absl::MutexLock lock(&mutex_);
    if (auto it = running_.find(id); it != running_.end()) {
      it->second.cancel = true;
    } else {
      for (Lane* lane : {&capture_lane_, &processing_lane_}) {
        auto q = std::find(lane->queue.begin(), lane->queue.end(), id);
        if (q != lane->queue.end()) {
          lane->queue.erase(q);
          was_queued = true;
        }
      }
      if (!was_queued) {
        return absl::FailedPreconditionError(absl::StrCat(
            "job ", id, " is already ", store::JobStateName(job.state)));
      }
    }
  }
  control_cv_.SignalAll();
  if (was_queued) {
    RETURN_IF_ERROR(
        jobs_.SetState(id, JobState::kCancelled, "cancelled before it started")
            .status());
    NotifyEvent();
  }
  return jobs_.Get(id);
}

absl::StatusOr<JobRecord> JobEngine::Continue(int64_t id) {
  ASSIGN_OR_RETURN(JobRecord job, jobs_.Get(id));
  {
    absl::MutexLock lock(&mutex_);
    auto it = running_.find(id);
    if (it == running_.end() || !it->second.waiting) {
      return absl::FailedPreconditionError(
          absl::StrCat("job ", id, " is ", store::JobStateName(job.state),
                       "; only a waiting job can be continued"));
    }
    // Recorded here rather than by the job when it wakes, so that the
    // caller reads the job as it goes on.
    RETURN_IF_ERROR(
        jobs_.SetState(id, JobState::kRunning, "continued by the operator")
            .status());
    // Read before the job can wake (it waits for mutex_) and move on.
    ASSIGN_OR_RETURN(job, jobs_.Get(id));
    it->second.continued = true;
    NotifyEventLocked();
  }
  control_cv_.SignalAll();
  return job;
}

void JobEngine::NotifyEvent() {
  absl::MutexLock lock(&mutex_);
  NotifyEventLocked();
}

void JobEngine::NotifyEventLocked() {
  ++event_generation_;
  event_cv_.SignalAll();
}

int64_t JobEngine::event_generation() {
  absl::MutexLock lock(&mutex_);
  return event_generation_;
}

bool JobEngine::stopping() {
  absl::MutexLock lock(&mutex_);
  return stopping_;
}

int64_t JobEngine::running_capture() {
  absl::MutexLock lock(&mutex_);
  return running_capture_;
}

void JobEngine::WaitForEvents(int64_t seen_generation, absl::Time deadline) {
  absl::MutexLock lock(&mutex_);
  while (!stopping_ && event_generation_ == seen_generation) {
    if (event_cv_.WaitWithDeadline(&mutex_, deadline)) return;  // timed out
  }
}

}  // namespace hdrstereo::jobs
