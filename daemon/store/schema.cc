// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/schema.h"

#include <algorithm>
#include <array>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

// Append only: a released migration is never edited. Times are Unix
// milliseconds (UTC); lengths in millimetres; exposures in seconds.
constexpr std::array<absl::string_view, 14> kMigrations = {
    // 1: the tables of DESIGN.md.
    R"sql(
CREATE TABLE rigs (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE,
  config_json TEXT NOT NULL DEFAULT '{}',
  create_time_ms INTEGER NOT NULL
);
CREATE TABLE sessions (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE,
  note TEXT NOT NULL DEFAULT '',
  rig_id INTEGER REFERENCES rigs(id),
  create_time_ms INTEGER NOT NULL
);
CREATE TABLE jobs (
  id INTEGER PRIMARY KEY,
  kind TEXT NOT NULL CHECK (kind IN ('capture', 'processing')),
  session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
  state TEXT NOT NULL CHECK (state IN ('queued', 'running', 'paused',
      'succeeded', 'failed', 'cancelled', 'interrupted')),
  request BLOB NOT NULL,
  progress_done INTEGER NOT NULL DEFAULT 0,
  progress_total INTEGER NOT NULL DEFAULT 0,
  step TEXT NOT NULL DEFAULT '',
  error TEXT NOT NULL DEFAULT '',
  create_time_ms INTEGER NOT NULL,
  start_time_ms INTEGER,
  end_time_ms INTEGER
);
CREATE INDEX jobs_by_session ON jobs(session_id);
CREATE INDEX jobs_by_state ON jobs(state);
CREATE TABLE job_events (
  id INTEGER PRIMARY KEY,
  job_id INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
  sequence INTEGER NOT NULL,
  time_ms INTEGER NOT NULL,
  state TEXT NOT NULL,
  progress_done INTEGER NOT NULL,
  progress_total INTEGER NOT NULL,
  step TEXT NOT NULL DEFAULT '',
  level TEXT NOT NULL DEFAULT 'info',
  message TEXT NOT NULL DEFAULT '',
  UNIQUE (job_id, sequence)
);
CREATE TABLE captures (
  id INTEGER PRIMARY KEY,
  session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
  job_id INTEGER REFERENCES jobs(id) ON DELETE SET NULL,
  kind TEXT NOT NULL CHECK (kind IN ('bracketed_stereo', 'structured_light',
      'calibration')),
  plan BLOB NOT NULL,
  create_time_ms INTEGER NOT NULL
);
CREATE TABLE frames (
  id INTEGER PRIMARY KEY,
  capture_id INTEGER NOT NULL REFERENCES captures(id) ON DELETE CASCADE,
  sequence INTEGER NOT NULL,
  view_index INTEGER NOT NULL,
  stage_position_mm REAL NOT NULL,
  exposure_s REAL NOT NULL,
  pattern TEXT NOT NULL DEFAULT '',
  inverse INTEGER NOT NULL DEFAULT 0,
  format TEXT NOT NULL,
  width_px INTEGER NOT NULL,
  height_px INTEGER NOT NULL,
  path TEXT NOT NULL,
  sha256 TEXT NOT NULL,
  camera_time_ms INTEGER,
  UNIQUE (capture_id, sequence),
  UNIQUE (path)
);
CREATE TABLE artifacts (
  id INTEGER PRIMARY KEY,
  session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
  job_id INTEGER REFERENCES jobs(id) ON DELETE SET NULL,
  kind TEXT NOT NULL,
  path TEXT NOT NULL,
  params_json TEXT NOT NULL DEFAULT '{}',
  params_hash TEXT NOT NULL DEFAULT '',
  sha256 TEXT NOT NULL,
  size_bytes INTEGER NOT NULL,
  create_time_ms INTEGER NOT NULL,
  UNIQUE (session_id, path)
);
CREATE TABLE metrics (
  id INTEGER PRIMARY KEY,
  session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
  job_id INTEGER REFERENCES jobs(id) ON DELETE SET NULL,
  method TEXT NOT NULL,
  ground_truth TEXT NOT NULL,
  rmse REAL,
  mae REAL,
  bad_0_5 REAL,
  bad_1 REAL,
  bad_2 REAL,
  bad_4 REAL,
  coverage REAL,
  create_time_ms INTEGER NOT NULL
);
CREATE TABLE schedules (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE,
  cron TEXT NOT NULL,
  time_zone TEXT NOT NULL DEFAULT 'UTC',
  enabled INTEGER NOT NULL DEFAULT 1,
  plan BLOB NOT NULL,
  missed_run_policy TEXT NOT NULL DEFAULT 'run_once_on_start',
  create_time_ms INTEGER NOT NULL
);
)sql",
    // 2: scheduled runs. `enable_time_ms` is when a schedule was (re)enabled:
    // due times before it are not missed runs.
    R"sql(
ALTER TABLE schedules ADD COLUMN enable_time_ms INTEGER;
CREATE TABLE schedule_runs (
  id INTEGER PRIMARY KEY,
  schedule_id INTEGER NOT NULL REFERENCES schedules(id) ON DELETE CASCADE,
  due_time_ms INTEGER NOT NULL,
  start_time_ms INTEGER,
  end_time_ms INTEGER,
  session TEXT NOT NULL DEFAULT '',
  job_ids TEXT NOT NULL DEFAULT '',
  outcome TEXT NOT NULL CHECK (outcome IN ('running', 'succeeded', 'failed',
      'skipped')),
  reason TEXT NOT NULL DEFAULT '',
  UNIQUE (schedule_id, due_time_ms)
);
CREATE INDEX schedule_runs_by_outcome ON schedule_runs(outcome);
)sql",
    // 3: processing. An artifact names the pipeline step that wrote it and
    // the hash of that step's inputs and parameters (params_hash), so an
    // unchanged step is not recomputed.
    R"sql(
ALTER TABLE artifacts ADD COLUMN step TEXT NOT NULL DEFAULT '';
CREATE INDEX artifacts_by_step ON artifacts(session_id, step);
CREATE INDEX metrics_by_session ON metrics(session_id);
)sql",
    // 4: remote operation. Who submitted each job and created (or last
    // enabled) each schedule, and on whose behalf a scheduled run ran; API
    // keys as id + salt + SHA-256 digest of the secret (hex; never the
    // secret itself);
    // the audit log; the rig lock (at most one row).
    R"sql(
ALTER TABLE jobs ADD COLUMN submitted_by TEXT NOT NULL DEFAULT '';
ALTER TABLE schedules ADD COLUMN created_by TEXT NOT NULL DEFAULT '';
ALTER TABLE schedules ADD COLUMN enabled_by TEXT NOT NULL DEFAULT '';
ALTER TABLE schedule_runs ADD COLUMN caused_by TEXT NOT NULL DEFAULT '';
CREATE TABLE api_keys (
  id TEXT PRIMARY KEY,
  salt TEXT NOT NULL,
  digest TEXT NOT NULL,
  user TEXT NOT NULL,
  role TEXT NOT NULL CHECK (role IN ('viewer', 'operator', 'admin')),
  note TEXT NOT NULL DEFAULT '',
  created_by TEXT NOT NULL,
  create_time_ms INTEGER NOT NULL,
  expire_time_ms INTEGER NOT NULL,
  last_used_time_ms INTEGER,
  revoke_time_ms INTEGER,
  revoked_by TEXT NOT NULL DEFAULT ''
);
CREATE TABLE audit (
  id INTEGER PRIMARY KEY,
  time_ms INTEGER NOT NULL,
  principal TEXT NOT NULL,
  role TEXT NOT NULL,
  auth_method TEXT NOT NULL,
  peer TEXT NOT NULL,
  method TEXT NOT NULL,
  subject TEXT NOT NULL DEFAULT '',
  status_code INTEGER NOT NULL,
  message TEXT NOT NULL DEFAULT ''
);
CREATE INDEX audit_by_time ON audit(time_ms);
CREATE INDEX audit_by_principal ON audit(principal, time_ms);
CREATE TABLE rig_lock (
  id INTEGER PRIMARY KEY CHECK (id = 1),
  holder TEXT NOT NULL,
  note TEXT NOT NULL DEFAULT '',
  lock_time_ms INTEGER NOT NULL,
  expire_time_ms INTEGER NOT NULL
);
)sql",
    // 5: unattended runs. What the camera reported for each frame (EXIF or
    // RAW metadata; NULL when the file carries none) and its own file name.
    R"sql(
ALTER TABLE frames ADD COLUMN camera_exposure_s REAL;
ALTER TABLE frames ADD COLUMN iso REAL;
ALTER TABLE frames ADD COLUMN aperture_f REAL;
ALTER TABLE frames ADD COLUMN camera_file_name TEXT NOT NULL DEFAULT '';
)sql",
    // 6: notifications (daemon/notify). Webhooks keep only the salt their
    // signing secret is derived from (with the data root's key); the outbox
    // holds one row per event and hook, each attempt one delivery row. The
    // outbox reads job events after a cursor and the schedule runs not yet
    // announced (runs from before this version count as announced).
    R"sql(
CREATE TABLE webhooks (
  id INTEGER PRIMARY KEY,
  url TEXT NOT NULL,
  events TEXT NOT NULL DEFAULT '',
  salt TEXT NOT NULL,
  note TEXT NOT NULL DEFAULT '',
  created_by TEXT NOT NULL,
  create_time_ms INTEGER NOT NULL
);
CREATE TABLE webhook_events (
  id INTEGER PRIMARY KEY,
  webhook_id INTEGER NOT NULL REFERENCES webhooks(id) ON DELETE CASCADE,
  event_id TEXT NOT NULL,
  type TEXT NOT NULL,
  body TEXT NOT NULL,
  state TEXT NOT NULL CHECK (state IN ('pending', 'delivered', 'abandoned')),
  attempts INTEGER NOT NULL DEFAULT 0,
  next_attempt_time_ms INTEGER NOT NULL,
  create_time_ms INTEGER NOT NULL,
  UNIQUE (webhook_id, event_id)
);
CREATE INDEX webhook_events_due ON webhook_events(state, next_attempt_time_ms);
CREATE TABLE webhook_deliveries (
  id INTEGER PRIMARY KEY,
  webhook_event_id INTEGER NOT NULL
      REFERENCES webhook_events(id) ON DELETE CASCADE,
  attempt INTEGER NOT NULL,
  time_ms INTEGER NOT NULL,
  duration_ms INTEGER NOT NULL,
  http_status INTEGER NOT NULL,
  error TEXT NOT NULL DEFAULT ''
);
CREATE INDEX webhook_deliveries_by_event ON webhook_deliveries(webhook_event_id);
CREATE TABLE notification_cursor (
  id INTEGER PRIMARY KEY CHECK (id = 1),
  job_event_id INTEGER NOT NULL
);
ALTER TABLE schedule_runs ADD COLUMN announced INTEGER NOT NULL DEFAULT 1;
CREATE INDEX schedule_runs_unannounced ON schedule_runs(id) WHERE announced = 0;
)sql",
    // 7: processing on a cluster. The batch job that runs a processing job,
    // so that a restarted daemon finds it again.
    R"sql(
ALTER TABLE jobs ADD COLUMN cluster_job_id INTEGER;
)sql",
    // 8: suspenders. Why a condition holds a job suspended ('' otherwise);
    // the event log keeps the history, this column the present.
    R"sql(
ALTER TABLE jobs ADD COLUMN suspension_reason TEXT NOT NULL DEFAULT '';
)sql",
    // 9: metrics. What a job event counts for (daemon/store/event_kind.h;
    // '' for events that are not counted), what it is about (the pipeline
    // step of a computed step) and how long it took; one row per device
    // call a capture job timed (a capture, a move, a projector pattern).
    R"sql(
ALTER TABLE job_events ADD COLUMN kind TEXT NOT NULL DEFAULT '';
ALTER TABLE job_events ADD COLUMN subject TEXT NOT NULL DEFAULT '';
ALTER TABLE job_events ADD COLUMN seconds REAL;
CREATE INDEX job_events_by_kind ON job_events(kind) WHERE kind != '';
CREATE TABLE device_time (
  id INTEGER PRIMARY KEY,
  job_id INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
  device TEXT NOT NULL CHECK (device IN ('camera', 'stage', 'projector')),
  seconds REAL NOT NULL,
  time_ms INTEGER NOT NULL
);
CREATE INDEX device_time_by_job ON device_time(job_id);
)sql",
    // 10: projector timing. What a structured-light capture measured of its
    // projector: the latency its probe found (NULL: not probed) and the
    // display's refresh rate (NULL: unknown).
    R"sql(
ALTER TABLE captures ADD COLUMN projector_latency_s REAL;
ALTER TABLE captures ADD COLUMN projector_refresh_hz REAL;
)sql",
    // 11: automatic bracketing. What a bracketed-stereo capture that chose
    // its exposures at the rig chose and why (hdr::AutoBracketResult's
    // canonical JSON; '' otherwise), kept so that a resumed capture takes
    // the same frames.
    R"sql(
ALTER TABLE captures ADD COLUMN auto_bracket TEXT NOT NULL DEFAULT '';
)sql",
    // 12: calibration captures wait for the operator. The instruction a
    // waiting job shows ('' otherwise). A waiting job is stored with state
    // 'paused' and a non-empty instruction (JobRepository reads it as
    // waiting): migration 1's CHECK on jobs.state cannot be widened without
    // rebuilding the table, which its foreign keys make risky.
    R"sql(
ALTER TABLE jobs ADD COLUMN instruction TEXT NOT NULL DEFAULT '';
)sql",
    // 13: the rig's calibrations. One row per calibration capture that was
    // calibrated: its files' folder (relative to the data root), the
    // stereo reprojection RMS, the per-pose RMS of each view (px, comma
    // separated) and the fraction of each view the boards covered.
    R"sql(
CREATE TABLE rig_calibrations (
  id INTEGER PRIMARY KEY,
  capture_id INTEGER NOT NULL REFERENCES captures(id) ON DELETE CASCADE,
  job_id INTEGER,
  dir TEXT NOT NULL,
  poses INTEGER NOT NULL,
  rms_stereo REAL NOT NULL,
  rms_left TEXT NOT NULL DEFAULT '',
  rms_right TEXT NOT NULL DEFAULT '',
  coverage_left REAL NOT NULL,
  coverage_right REAL NOT NULL,
  create_time_ms INTEGER NOT NULL
);
)sql",
    // 14: the HTTP edge. How each audited call came: 'grpc' (a network
    // port: every row written before this version), 'http' (the daemon's
    // HTTP edge, whose peer is the HTTP client's address) or 'in-process'
    // (an in-process call without the edge's stamp, refused); '' for the
    // audit log's own notes.
    R"sql(
ALTER TABLE audit ADD COLUMN transport TEXT NOT NULL DEFAULT 'grpc';
)sql",
};

}  // namespace

int LatestSchemaVersion() { return static_cast<int>(kMigrations.size()); }

absl::StatusOr<int> ReadSchemaVersion(Database& db) {
  ASSIGN_OR_RETURN(
      Statement has_table,
      db.Prepare("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND "
                 "name = 'schema_version'"));
  RETURN_IF_ERROR(has_table.Step().status());
  if (has_table.ColumnInt(0) == 0) {
    // No version table: acceptable only for a database with no tables at all.
    ASSIGN_OR_RETURN(
        Statement any,
        db.Prepare("SELECT count(*) FROM sqlite_master WHERE type = 'table'"));
    RETURN_IF_ERROR(any.Step().status());
    if (any.ColumnInt(0) != 0) {
      return absl::FailedPreconditionError(
          absl::StrCat(db.path().string(),
                       " has tables but no schema_version table: it is not an "
                       "hdrstereo database"));
    }
    return 0;
  }
  ASSIGN_OR_RETURN(
      Statement max,
      db.Prepare("SELECT coalesce(max(version), 0) FROM schema_version"));
  RETURN_IF_ERROR(max.Step().status());
  return static_cast<int>(max.ColumnInt(0));
}

absl::StatusOr<int> Migrate(Database& db, int target) {
  int version;
  {
    absl::MutexLock lock(&db.mutex());
    ASSIGN_OR_RETURN(int current, ReadSchemaVersion(db));
    version = current;
  }
  if (version > LatestSchemaVersion()) {
    return absl::FailedPreconditionError(absl::StrCat(
        db.path().string(), " has schema version ", version,
        ", newer than this hdrstereod supports (", LatestSchemaVersion(),
        "); refusing to open it: use a newer hdrstereod"));
  }
  while (version < std::min(target, LatestSchemaVersion())) {
    Transaction tx(db);
    RETURN_IF_ERROR(tx.status());
    RETURN_IF_ERROR(db.Exec(
        "CREATE TABLE IF NOT EXISTS schema_version ("
        "version INTEGER PRIMARY KEY, apply_time_ms INTEGER NOT NULL)"));
    if (absl::Status s = db.Exec(kMigrations[version]); !s.ok()) {
      return absl::Status(
          s.code(), absl::StrCat("migration to version ", version + 1, ": ",
                                 s.message()));
    }
    ASSIGN_OR_RETURN(Statement record,
                     db.Prepare("INSERT INTO schema_version (version, "
                                "apply_time_ms) VALUES (?1, ?2)"));
    RETURN_IF_ERROR(record.Bind(1, int64_t{version + 1})
                        .Bind(2, absl::ToUnixMillis(absl::Now()))
                        .Run());
    RETURN_IF_ERROR(tx.Commit());
    ++version;
  }
  return version;
}

}  // namespace hdrstereo::store
