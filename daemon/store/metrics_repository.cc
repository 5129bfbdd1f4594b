// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/metrics_repository.h"

#include "daemon/store/database.h"
#include "daemon/store/job_repository.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

absl::StatusOr<int64_t> Count(Database& db, absl::string_view sql)
    ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex()) {
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare(sql));
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  return row ? stmt.ColumnInt(0) : 0;
}

}  // namespace

absl::StatusOr<StoreTotals> MetricsRepository::Read() {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  StoreTotals totals;
  for (JobState state :
       {JobState::kQueued, JobState::kRunning, JobState::kPaused,
        JobState::kSucceeded, JobState::kFailed, JobState::kCancelled,
        JobState::kInterrupted}) {
    totals.jobs_by_state[JobStateName(state)] = 0;
  }
  ASSIGN_OR_RETURN(
      Statement states,
      db.Prepare("SELECT state, count(*) FROM jobs GROUP BY state"));
  for (;;) {
    ASSIGN_OR_RETURN(bool row, states.Step());
    if (!row) break;
    totals.jobs_by_state[states.ColumnText(0)] = states.ColumnInt(1);
  }
  ASSIGN_OR_RETURN(totals.frames, Count(db, "SELECT count(*) FROM frames"));
  ASSIGN_OR_RETURN(totals.frames_verified,
                   Count(db,
                         "SELECT count(*) FROM frames WHERE camera_file_name "
                         "!= '' OR camera_exposure_s IS NOT NULL"));
  ASSIGN_OR_RETURN(totals.suspensions,
                   Count(db,
                         "SELECT count(*) FROM job_events "
                         "WHERE message LIKE 'suspended%'"));
  // The first event at which a capture job's frame count reached n marks
  // frame n; the time from frame n-1 to frame n is one frame's time (frame
  // 1's includes the job's start-up, so it is left out).
  ASSIGN_OR_RETURN(Statement frames, db.Prepare(R"sql(
SELECT time_ms - LAG(time_ms) OVER w, done - LAG(done) OVER w FROM (
  SELECT e.job_id, e.progress_done AS done, MIN(e.time_ms) AS time_ms
  FROM job_events e JOIN jobs j ON j.id = e.job_id
  WHERE j.kind = 'capture' AND e.progress_done > 0
  GROUP BY e.job_id, e.progress_done)
WINDOW w AS (PARTITION BY job_id ORDER BY done)
)sql"));
  for (;;) {
    ASSIGN_OR_RETURN(bool row, frames.Step());
    if (!row) break;
    if (frames.ColumnIsNull(1) || frames.ColumnInt(1) != 1) continue;
    totals.frame_seconds.push_back(frames.ColumnDouble(0) / 1000.0);
  }
  for (EventFamily family :
       {EventFamily::kVerificationFailure, EventFamily::kDeviceError}) {
    for (EventKind kind : KindsOf(family)) totals.events_by_kind[kind] = 0;
  }
  ASSIGN_OR_RETURN(Statement kinds, db.Prepare(R"sql(
SELECT kind, count(*) FROM job_events WHERE kind != '' GROUP BY kind)sql"));
  for (;;) {
    ASSIGN_OR_RETURN(bool row, kinds.Step());
    if (!row) break;
    ASSIGN_OR_RETURN(EventKind kind, ParseEventKind(kinds.ColumnText(0)));
    if (totals.events_by_kind.contains(kind)) {
      totals.events_by_kind[kind] = kinds.ColumnInt(1);
    }
  }
  for (Device device : kAllDevices) totals.device_seconds[device] = {};
  ASSIGN_OR_RETURN(Statement calls,
                   db.Prepare("SELECT device, seconds FROM device_time"));
  for (;;) {
    ASSIGN_OR_RETURN(bool row, calls.Step());
    if (!row) break;
    ASSIGN_OR_RETURN(Device device, ParseDevice(calls.ColumnText(0)));
    totals.device_seconds[device].push_back(calls.ColumnDouble(1));
  }
  ASSIGN_OR_RETURN(Statement steps, db.Prepare(R"sql(
SELECT subject, seconds FROM job_events
WHERE kind = ?1 AND seconds IS NOT NULL)sql"));
  steps.Bind(1, EventKindName(EventKind::kStepComputed));
  for (;;) {
    ASSIGN_OR_RETURN(bool row, steps.Step());
    if (!row) break;
    totals.step_seconds[steps.ColumnText(0)].push_back(steps.ColumnDouble(1));
  }
  return totals;
}

}  // namespace hdrstereo::store
