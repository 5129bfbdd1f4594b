// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/metrics_repository.h"

#include <mutex>

#include "daemon/store/database.h"
#include "daemon/store/job_repository.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

absl::StatusOr<int64_t> Count(Database& db, absl::string_view sql) {
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare(sql));
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  return row ? stmt.ColumnInt(0) : 0;
}

}  // namespace

absl::StatusOr<StoreTotals> MetricsRepository::Read() {
  Database& db = store_.db();
  std::unique_lock<std::mutex> lock = db.Lock();
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
  // A capture job's progress events count frames; the time between two
  // that advance the count is one frame's time.
  ASSIGN_OR_RETURN(Statement frames, db.Prepare(R"sql(
SELECT time_ms - prev_ms FROM (
  SELECT e.time_ms, e.progress_done,
         LAG(e.time_ms) OVER w AS prev_ms,
         LAG(e.progress_done) OVER w AS prev_done
  FROM job_events e JOIN jobs j ON j.id = e.job_id
  WHERE j.kind = 'capture' AND e.state = 'running'
  WINDOW w AS (PARTITION BY e.job_id ORDER BY e.sequence))
WHERE prev_done IS NOT NULL AND prev_done > 0 AND progress_done = prev_done + 1
)sql"));
  for (;;) {
    ASSIGN_OR_RETURN(bool row, frames.Step());
    if (!row) break;
    totals.frame_seconds.push_back(frames.ColumnDouble(0) / 1000.0);
  }
  return totals;
}

}  // namespace hdrstereo::store
