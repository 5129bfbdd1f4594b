// SPDX-License-Identifier: GPL-3.0-or-later
//
// Jobs and their event history (tables `jobs` and `job_events`). Every state
// or progress change is one transaction that also appends its event, so the
// history a late watcher replays is exactly what happened.
#ifndef HDRSTEREO_DAEMON_STORE_JOB_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_JOB_REPOSITORY_H_

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/store/event_kind.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

enum class JobState {
  kQueued,
  kRunning,
  kPaused,
  kSucceeded,
  kFailed,
  kCancelled,
  kInterrupted,
  // A calibration capture waits for the operator (JobRecord::instruction):
  // stored as 'paused' with the instruction (schema migration 11).
  kWaiting,
};
const char* JobStateName(JobState state);  // as stored: "queued", ...
absl::StatusOr<JobState> ParseJobState(absl::string_view name);
bool IsFinal(JobState state);  // succeeded, failed, cancelled

enum class JobKind { kCapture, kProcessing };

struct JobRecord {
  int64_t id = 0;
  JobKind kind = JobKind::kCapture;
  int64_t session_id = 0;
  std::string session;
  JobState state = JobState::kQueued;
  std::string request;  // serialized request proto
  int64_t progress_done = 0;
  int64_t progress_total = 0;
  std::string step;
  std::string error;
  int64_t create_time_ms = 0;
  std::optional<int64_t> start_time_ms;
  std::optional<int64_t> end_time_ms;
  std::string submitted_by;  // principal; "" for jobs from before it was kept
  // The batch job on the cluster that runs this processing job (Slurm's job
  // id), once submitted.
  std::optional<int64_t> cluster_job_id;
  // While a condition suspends the job (state paused): why, e.g. "the
  // camera battery is at 12%, below --min-battery-percent 20%"; "" otherwise.
  std::string suspension_reason;
  // While the job waits for the operator (state waiting): what to do before
  // continuing it, e.g. "place the board in pose 3 of 8 and continue";
  // "" otherwise.
  std::string instruction;
};

enum class EventLevel { kInfo, kWarning, kError };

// What the metrics count an event as (daemon/store/event_kind.h); most
// events are not counted.
struct EventTag {
  EventTag() = default;
  explicit EventTag(EventKind kind) : kind(kind) {}
  EventTag(EventKind kind, std::string subject, double seconds)
      : kind(kind), subject(std::move(subject)), seconds(seconds) {}

  EventKind kind = EventKind::kNone;
  std::string subject;            // kStepComputed: the pipeline step
  std::optional<double> seconds;  // kStepComputed: how long it took
};

struct JobEventRecord {
  int64_t job_id = 0;
  int64_t sequence = 0;
  int64_t time_ms = 0;
  JobState state = JobState::kQueued;
  int64_t progress_done = 0;
  int64_t progress_total = 0;
  std::string step;
  EventLevel level = EventLevel::kInfo;
  std::string message;
  EventTag tag;
};

// A job event with its job and the state of the job's event before it
// (nullopt for its first), as notifications read them.
struct JobEventRow {
  int64_t row_id = 0;  // job_events.id: increases with every event recorded
  JobEventRecord event;
  JobRecord job;
  std::optional<JobState> previous_state;
};

struct JobFilter {
  std::string session;           // empty = all
  std::vector<JobState> states;  // empty = all
  int64_t after_id = 0;          // pagination: ids greater than this
  int limit = 100;
};

class JobRepository {
 public:
  explicit JobRepository(Store& store) : store_(store) {}

  // Queues a job of `total` units (frames, steps) for an existing session
  // (NOT_FOUND otherwise), submitted by the principal `submitted_by`, and
  // records its first event.
  absl::StatusOr<JobRecord> Create(JobKind kind, absl::string_view session,
                                   absl::string_view request, int64_t total,
                                   absl::string_view message,
                                   absl::string_view submitted_by);
  absl::StatusOr<JobRecord> Get(int64_t id);
  absl::StatusOr<std::vector<JobRecord>> List(const JobFilter& filter);

  // Changes the state (setting start/end times as fitting) and appends an
  // event, tagged with `tag`. `error` is stored for failed jobs. Any state
  // change ends a suspension (the reason is cleared).
  absl::StatusOr<JobEventRecord> SetState(int64_t id, JobState state,
                                          absl::string_view message,
                                          absl::string_view error = "",
                                          const EventTag& tag = {});
  // A condition suspends the job: state paused, `reason` kept as its
  // suspension_reason, event "suspended: <reason>".
  absl::StatusOr<JobEventRecord> Suspend(int64_t id, absl::string_view reason);
  // The job waits for the operator: state waiting, `instruction` kept,
  // event "waiting: <instruction>".
  absl::StatusOr<JobEventRecord> Wait(int64_t id,
                                      absl::string_view instruction);
  // The condition of a suspended job says something new (e.g. the next
  // reconnect attempt): only the reason changes; no event.
  absl::Status UpdateSuspensionReason(int64_t id, absl::string_view reason);
  // The condition cleared while the state stays (a person's pause outlasts
  // it): the reason is cleared and the info event `message` appended.
  absl::StatusOr<JobEventRecord> EndSuspension(int64_t id,
                                               absl::string_view message);
  // Appends a warning or info event without changing the job.
  absl::StatusOr<JobEventRecord> AddEvent(int64_t id, EventLevel level,
                                          absl::string_view message,
                                          const EventTag& tag = {});

  absl::StatusOr<std::vector<JobEventRecord>> Events(int64_t id,
                                                     int64_t after_sequence);

  // Records the cluster's job id for `id` and, in the same transaction, an
  // info event saying so.
  absl::StatusOr<JobEventRecord> SetClusterJob(int64_t id,
                                               int64_t cluster_job_id,
                                               absl::string_view message);

  // Every job's events with row ids above `after_row_id`, oldest first.
  absl::StatusOr<std::vector<JobEventRow>> EventsAfterRow(int64_t after_row_id,
                                                          int limit);

  // Start-up: every job left running or paused by a previous process
  // becomes interrupted. Returns their ids, oldest first.
  absl::StatusOr<std::vector<int64_t>> InterruptUnfinished();

  // Inside an open transaction (the caller holds it): progress update and
  // its event, for callers that commit other rows in the same transaction
  // (e.g. a frame and the progress it advances). Checks at run time that the
  // database's mutex is held.
  absl::StatusOr<JobEventRecord> SetProgressLocked(int64_t id, int64_t done,
                                                   int64_t total,
                                                   absl::string_view step);

 private:
  // SetState, keeping `suspension_reason` and `instruction` with the new
  // state.
  absl::StatusOr<JobEventRecord> ChangeState(
      int64_t id, JobState state, absl::string_view message,
      absl::string_view error, absl::string_view suspension_reason,
      const EventTag& tag, absl::string_view instruction = "");
  // In one transaction: `update` (?1: the job's id, ?2: `value`) and the
  // info event `message`.
  template <typename T>
  absl::StatusOr<JobEventRecord> UpdateWithEvent(int64_t id,
                                                 absl::string_view update,
                                                 const T& value,
                                                 absl::string_view message);
  static absl::StatusOr<JobEventRecord> AppendEventLocked(
      Database& db, int64_t id, EventLevel level, absl::string_view message,
      const EventTag& tag = {}) ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex());
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_JOB_REPOSITORY_H_
