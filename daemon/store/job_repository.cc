// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/job_repository.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

constexpr struct {
  JobState state;
  const char* name;
} kStateNames[] = {
    {JobState::kQueued, "queued"},
    {JobState::kRunning, "running"},
    {JobState::kPaused, "paused"},
    {JobState::kSucceeded, "succeeded"},
    {JobState::kFailed, "failed"},
    {JobState::kCancelled, "cancelled"},
    {JobState::kInterrupted, "interrupted"},
    {JobState::kWaiting, "waiting"},
};

// The jobs.state a state is stored as (see JobState::kWaiting).
const char* StoredStateName(JobState state) {
  return state == JobState::kWaiting ? "paused" : JobStateName(state);
}

const char* LevelName(EventLevel level) {
  switch (level) {
    case EventLevel::kInfo:
      return "info";
    case EventLevel::kWarning:
      return "warning";
    case EventLevel::kError:
      return "error";
  }
  return "info";
}

EventLevel ParseLevel(absl::string_view name) {
  if (name == "warning") return EventLevel::kWarning;
  if (name == "error") return EventLevel::kError;
  return EventLevel::kInfo;
}

int64_t NowMs() { return absl::ToUnixMillis(absl::Now()); }

// The tag of an event row whose kind, subject and seconds are the columns
// from `first` on.
absl::StatusOr<EventTag> ReadTag(const Statement& stmt, int first) {
  EventTag tag;
  ASSIGN_OR_RETURN(tag.kind, ParseEventKind(stmt.ColumnText(first)));
  tag.subject = stmt.ColumnText(first + 1);
  if (!stmt.ColumnIsNull(first + 2)) tag.seconds = stmt.ColumnDouble(first + 2);
  return tag;
}

constexpr absl::string_view kSelectJob = R"sql(
SELECT j.id, j.kind, j.session_id, s.name, j.state, j.request,
       j.progress_done, j.progress_total, j.step, j.error, j.create_time_ms,
       j.start_time_ms, j.end_time_ms, j.submitted_by, j.cluster_job_id,
       j.suspension_reason, j.instruction
FROM jobs j JOIN sessions s ON s.id = j.session_id
)sql";

absl::StatusOr<JobRecord> ReadJob(const Statement& stmt) {
  JobRecord job;
  job.id = stmt.ColumnInt(0);
  job.kind = stmt.ColumnText(1) == "capture" ? JobKind::kCapture
                                             : JobKind::kProcessing;
  job.session_id = stmt.ColumnInt(2);
  job.session = stmt.ColumnText(3);
  ASSIGN_OR_RETURN(JobState state, ParseJobState(stmt.ColumnText(4)));
  job.state = state;
  job.request = stmt.ColumnText(5);
  job.progress_done = stmt.ColumnInt(6);
  job.progress_total = stmt.ColumnInt(7);
  job.step = stmt.ColumnText(8);
  job.error = stmt.ColumnText(9);
  job.create_time_ms = stmt.ColumnInt(10);
  if (!stmt.ColumnIsNull(11)) job.start_time_ms = stmt.ColumnInt(11);
  if (!stmt.ColumnIsNull(12)) job.end_time_ms = stmt.ColumnInt(12);
  job.submitted_by = stmt.ColumnText(13);
  if (!stmt.ColumnIsNull(14)) job.cluster_job_id = stmt.ColumnInt(14);
  job.suspension_reason = stmt.ColumnText(15);
  job.instruction = stmt.ColumnText(16);
  if (job.state == JobState::kPaused && !job.instruction.empty()) {
    job.state = JobState::kWaiting;
  }
  return job;
}

absl::StatusOr<JobRecord> GetLocked(Database& db, int64_t id)
    ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex()) {
  ASSIGN_OR_RETURN(Statement stmt,
                   db.Prepare(absl::StrCat(kSelectJob, "WHERE j.id = ?1")));
  stmt.Bind(1, id);
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) return absl::NotFoundError(absl::StrCat("no job ", id));
  return ReadJob(stmt);
}

}  // namespace

const char* JobStateName(JobState state) {
  for (const auto& entry : kStateNames) {
    if (entry.state == state) return entry.name;
  }
  return "unknown";
}

absl::StatusOr<JobState> ParseJobState(absl::string_view name) {
  for (const auto& entry : kStateNames) {
    if (name == entry.name) return entry.state;
  }
  return absl::DataLossError(absl::StrCat("unknown job state \"", name, "\""));
}

bool IsFinal(JobState state) {
  return state == JobState::kSucceeded || state == JobState::kFailed ||
         state == JobState::kCancelled;
}

absl::StatusOr<JobEventRecord> JobRepository::AppendEventLocked(
    Database& db, int64_t id, EventLevel level, absl::string_view message,
    const EventTag& tag) {
  ASSIGN_OR_RETURN(JobRecord job, GetLocked(db, id));
  ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT INTO job_events (job_id, sequence, time_ms, state, progress_done,
                        progress_total, step, level, message, kind, subject,
                        seconds)
VALUES (?1, (SELECT coalesce(max(sequence), 0) + 1 FROM job_events
             WHERE job_id = ?1), ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)
RETURNING sequence)sql"));
  JobEventRecord event{.job_id = id,
                       .time_ms = NowMs(),
                       .state = job.state,
                       .progress_done = job.progress_done,
                       .progress_total = job.progress_total,
                       .step = job.step,
                       .level = level,
                       .message = std::string(message),
                       .tag = tag};
  insert.Bind(1, id)
      .Bind(2, event.time_ms)
      .Bind(3, JobStateName(event.state))
      .Bind(4, event.progress_done)
      .Bind(5, event.progress_total)
      .Bind(6, event.step)
      .Bind(7, LevelName(level))
      .Bind(8, message)
      .Bind(9, EventKindName(tag.kind))
      .Bind(10, tag.subject);
  if (tag.seconds.has_value()) {
    insert.Bind(11, *tag.seconds);
  } else {
    insert.BindNull(11);
  }
  RETURN_IF_ERROR(insert.Step().status());
  event.sequence = insert.ColumnInt(0);
  return event;
}

absl::StatusOr<JobRecord> JobRepository::Create(
    JobKind kind, absl::string_view session, absl::string_view request,
    int64_t total, absl::string_view message, absl::string_view submitted_by) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT INTO jobs (kind, session_id, state, request, create_time_ms,
                  progress_total, submitted_by)
SELECT ?1, id, 'queued', ?2, ?3, ?5, ?6 FROM sessions WHERE name = ?4)sql"));
  RETURN_IF_ERROR(
      insert.Bind(1, kind == JobKind::kCapture ? "capture" : "processing")
          .Bind(2, request)
          .Bind(3, NowMs())
          .Bind(4, session)
          .Bind(5, total)
          .Bind(6, submitted_by)
          .Run());
  if (db.Changes() == 0) {
    return absl::NotFoundError(
        absl::StrCat("no session named \"", session, "\""));
  }
  const int64_t id = db.LastInsertId();
  RETURN_IF_ERROR(
      AppendEventLocked(db, id, EventLevel::kInfo, message).status());
  ASSIGN_OR_RETURN(JobRecord job, GetLocked(db, id));
  RETURN_IF_ERROR(tx.Commit());
  return job;
}

absl::StatusOr<std::vector<JobEventRow>> JobRepository::EventsAfterRow(
    int64_t after_row_id, int limit) {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare(R"sql(
SELECT e.id, e.sequence, e.time_ms, e.state, e.progress_done,
       e.progress_total, e.step, e.level, e.message,
       (SELECT p.state FROM job_events p
        WHERE p.job_id = e.job_id AND p.sequence < e.sequence
        ORDER BY p.sequence DESC LIMIT 1),
       e.job_id, e.kind, e.subject, e.seconds
FROM job_events e WHERE e.id > ?1 ORDER BY e.id LIMIT ?2)sql"));
  stmt.Bind(1, after_row_id).Bind(2, int64_t{limit});
  std::vector<JobEventRow> rows;
  while (true) {
    ASSIGN_OR_RETURN(bool more, stmt.Step());
    if (!more) break;
    JobEventRow row;
    row.row_id = stmt.ColumnInt(0);
    JobEventRecord& event = row.event;
    event.job_id = stmt.ColumnInt(10);
    event.sequence = stmt.ColumnInt(1);
    event.time_ms = stmt.ColumnInt(2);
    ASSIGN_OR_RETURN(JobState state, ParseJobState(stmt.ColumnText(3)));
    event.state = state;
    event.progress_done = stmt.ColumnInt(4);
    event.progress_total = stmt.ColumnInt(5);
    event.step = stmt.ColumnText(6);
    event.level = ParseLevel(stmt.ColumnText(7));
    event.message = stmt.ColumnText(8);
    ASSIGN_OR_RETURN(event.tag, ReadTag(stmt, 11));
    if (!stmt.ColumnIsNull(9)) {
      ASSIGN_OR_RETURN(JobState previous, ParseJobState(stmt.ColumnText(9)));
      row.previous_state = previous;
    }
    ASSIGN_OR_RETURN(JobRecord job, GetLocked(db, event.job_id));
    row.job = std::move(job);
    rows.push_back(std::move(row));
  }
  return rows;
}

absl::StatusOr<JobRecord> JobRepository::Get(int64_t id) {
  absl::MutexLock lock(&store_.db().mutex());
  return GetLocked(store_.db(), id);
}

absl::StatusOr<std::vector<JobRecord>> JobRepository::List(
    const JobFilter& filter) {
  std::vector<std::string> where = {"j.id > ?1"};
  if (!filter.session.empty()) where.push_back("s.name = ?2");
  if (!filter.states.empty()) {
    std::vector<std::string> names;
    for (JobState state : filter.states) {
      if (state == JobState::kWaiting) {
        names.push_back("(j.state = 'paused' AND j.instruction != '')");
      } else if (state == JobState::kPaused) {
        names.push_back("(j.state = 'paused' AND j.instruction = '')");
      } else {
        names.push_back(absl::StrCat("j.state = '", JobStateName(state), "'"));
      }
    }
    where.push_back(absl::StrCat("(", absl::StrJoin(names, " OR "), ")"));
  }
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt,
                   store_.db().Prepare(absl::StrCat(
                       kSelectJob, "WHERE ", absl::StrJoin(where, " AND "),
                       " ORDER BY j.id LIMIT ?3")));
  stmt.Bind(1, filter.after_id)
      .Bind(2, filter.session)
      .Bind(3, int64_t{filter.limit});
  std::vector<JobRecord> jobs;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    ASSIGN_OR_RETURN(JobRecord job, ReadJob(stmt));
    jobs.push_back(std::move(job));
  }
  return jobs;
}

template <typename T>
absl::StatusOr<JobEventRecord> JobRepository::UpdateWithEvent(
    int64_t id, absl::string_view update, const T& value,
    absl::string_view message) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare(update));
  RETURN_IF_ERROR(stmt.Bind(1, id).Bind(2, value).Run());
  ASSIGN_OR_RETURN(JobEventRecord event,
                   AppendEventLocked(db, id, EventLevel::kInfo, message));
  RETURN_IF_ERROR(tx.Commit());
  return event;
}

absl::StatusOr<JobEventRecord> JobRepository::SetState(
    int64_t id, JobState state, absl::string_view message,
    absl::string_view error, const EventTag& tag) {
  return ChangeState(id, state, message, error, "", tag);
}

absl::StatusOr<JobEventRecord> JobRepository::Suspend(
    int64_t id, absl::string_view reason) {
  return ChangeState(id, JobState::kPaused, absl::StrCat("suspended: ", reason),
                     "", reason, {});
}

absl::StatusOr<JobEventRecord> JobRepository::Wait(
    int64_t id, absl::string_view instruction) {
  return ChangeState(id, JobState::kWaiting,
                     absl::StrCat("waiting: ", instruction), "", "", {},
                     instruction);
}

absl::Status JobRepository::UpdateSuspensionReason(int64_t id,
                                                   absl::string_view reason) {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(Statement update,
                   db.Prepare("UPDATE jobs SET suspension_reason = ?2 "
                              "WHERE id = ?1 AND suspension_reason != ''"));
  return update.Bind(1, id).Bind(2, reason).Run();
}

absl::StatusOr<JobEventRecord> JobRepository::EndSuspension(
    int64_t id, absl::string_view message) {
  return UpdateWithEvent(id,
                         "UPDATE jobs SET suspension_reason = ?2 WHERE id = ?1",
                         absl::string_view(""), message);  // not NULL
}

absl::StatusOr<JobEventRecord> JobRepository::ChangeState(
    int64_t id, JobState state, absl::string_view message,
    absl::string_view error, absl::string_view suspension_reason,
    const EventTag& tag, absl::string_view instruction) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(Statement update, db.Prepare(R"sql(
UPDATE jobs SET state = ?2, error = ?3, suspension_reason = ?5,
  instruction = ?6,
  start_time_ms = CASE WHEN ?2 = 'running' AND start_time_ms IS NULL
                       THEN ?4 ELSE start_time_ms END,
  end_time_ms = CASE WHEN ?2 IN ('succeeded', 'failed', 'cancelled')
                     THEN ?4 ELSE NULL END
WHERE id = ?1)sql"));
  RETURN_IF_ERROR(update.Bind(1, id)
                      .Bind(2, StoredStateName(state))
                      .Bind(3, error)
                      .Bind(4, NowMs())
                      .Bind(5, suspension_reason)
                      .Bind(6, instruction)
                      .Run());
  if (db.Changes() == 0)
    return absl::NotFoundError(absl::StrCat("no job ", id));
  ASSIGN_OR_RETURN(
      JobEventRecord event,
      AppendEventLocked(
          db, id,
          state == JobState::kFailed ? EventLevel::kError : EventLevel::kInfo,
          message, tag));
  RETURN_IF_ERROR(tx.Commit());
  return event;
}

absl::StatusOr<JobEventRecord> JobRepository::SetProgressLocked(
    int64_t id, int64_t done, int64_t total, absl::string_view step) {
  Database& db = store_.db();
  db.AssertHeld();
  ASSIGN_OR_RETURN(
      Statement update,
      db.Prepare(
          "UPDATE jobs SET progress_done = ?2, progress_total = ?3, step = ?4 "
          "WHERE id = ?1"));
  RETURN_IF_ERROR(
      update.Bind(1, id).Bind(2, done).Bind(3, total).Bind(4, step).Run());
  return AppendEventLocked(db, id, EventLevel::kInfo, "");
}

absl::StatusOr<JobEventRecord> JobRepository::AddEvent(
    int64_t id, EventLevel level, absl::string_view message,
    const EventTag& tag) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(JobEventRecord event,
                   AppendEventLocked(db, id, level, message, tag));
  RETURN_IF_ERROR(tx.Commit());
  return event;
}

absl::StatusOr<JobEventRecord> JobRepository::SetClusterJob(
    int64_t id, int64_t cluster_job_id, absl::string_view message) {
  return UpdateWithEvent(id,
                         "UPDATE jobs SET cluster_job_id = ?2 WHERE id = ?1",
                         cluster_job_id, message);
}

absl::StatusOr<std::vector<JobEventRecord>> JobRepository::Events(
    int64_t id, int64_t after_sequence) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt, store_.db().Prepare(R"sql(
SELECT sequence, time_ms, state, progress_done, progress_total, step, level,
       message, kind, subject, seconds
FROM job_events WHERE job_id = ?1 AND sequence > ?2 ORDER BY sequence)sql"));
  stmt.Bind(1, id).Bind(2, after_sequence);
  std::vector<JobEventRecord> events;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    ASSIGN_OR_RETURN(JobState state, ParseJobState(stmt.ColumnText(2)));
    ASSIGN_OR_RETURN(EventTag tag, ReadTag(stmt, 8));
    events.push_back({.job_id = id,
                      .sequence = stmt.ColumnInt(0),
                      .time_ms = stmt.ColumnInt(1),
                      .state = state,
                      .progress_done = stmt.ColumnInt(3),
                      .progress_total = stmt.ColumnInt(4),
                      .step = stmt.ColumnText(5),
                      .level = ParseLevel(stmt.ColumnText(6)),
                      .message = stmt.ColumnText(7),
                      .tag = std::move(tag)});
  }
  return events;
}

absl::StatusOr<std::vector<int64_t>> JobRepository::InterruptUnfinished() {
  std::vector<int64_t> ids;
  {
    absl::MutexLock lock(&store_.db().mutex());
    ASSIGN_OR_RETURN(Statement stmt,
                     store_.db().Prepare("SELECT id FROM jobs WHERE state IN "
                                         "('running', 'paused') ORDER BY id"));
    while (true) {
      ASSIGN_OR_RETURN(bool row, stmt.Step());
      if (!row) break;
      ids.push_back(stmt.ColumnInt(0));
    }
  }
  for (int64_t id : ids) {
    RETURN_IF_ERROR(SetState(id, JobState::kInterrupted,
                             "the daemon stopped while this job ran")
                        .status());
  }
  return ids;
}

}  // namespace hdrstereo::store
