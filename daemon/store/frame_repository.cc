// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/frame_repository.h"

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

constexpr absl::string_view kSelectFrame = R"sql(
SELECT f.id, f.capture_id, c.kind, f.sequence, f.view_index,
       f.stage_position_mm, f.exposure_s, f.pattern, f.inverse, f.format,
       f.width_px, f.height_px, f.path, f.sha256, f.camera_time_ms,
       f.camera_exposure_s, f.iso, f.aperture_f, f.camera_file_name
FROM frames f JOIN captures c ON c.id = f.capture_id
)sql";

absl::StatusOr<io::CaptureKind> KindOf(const std::string& name) {
  absl::StatusOr<io::CaptureKind> kind = io::ParseCaptureKind(name);
  if (!kind.ok()) {
    return absl::DataLossError(
        absl::StrCat("captures row: ", kind.status().message()));
  }
  return kind;
}

absl::StatusOr<FrameRecord> ReadFrame(const Statement& stmt) {
  FrameRecord f;
  f.id = stmt.ColumnInt(0);
  f.capture_id = stmt.ColumnInt(1);
  ASSIGN_OR_RETURN(f.capture_kind, KindOf(stmt.ColumnText(2)));
  f.sequence = static_cast<int>(stmt.ColumnInt(3));
  f.view_index = static_cast<int>(stmt.ColumnInt(4));
  f.stage_position_mm = stmt.ColumnDouble(5);
  f.exposure_s = stmt.ColumnDouble(6);
  f.pattern = stmt.ColumnText(7);
  f.inverse = stmt.ColumnInt(8) != 0;
  const std::string format = stmt.ColumnText(9);
  const std::optional<hardware::ImageFormat> parsed =
      hardware::ParseImageFormat(format);
  if (!parsed) {
    return absl::DataLossError(
        absl::StrCat("frame ", f.id, ": format \"", format, "\" is not known"));
  }
  f.format = *parsed;
  f.width_px = static_cast<int>(stmt.ColumnInt(10));
  f.height_px = static_cast<int>(stmt.ColumnInt(11));
  f.path = stmt.ColumnText(12);
  f.sha256 = stmt.ColumnText(13);
  if (!stmt.ColumnIsNull(14)) f.camera_time_ms = stmt.ColumnInt(14);
  if (!stmt.ColumnIsNull(15)) f.camera_exposure_s = stmt.ColumnDouble(15);
  if (!stmt.ColumnIsNull(16)) f.iso = stmt.ColumnDouble(16);
  if (!stmt.ColumnIsNull(17)) f.aperture_f = stmt.ColumnDouble(17);
  f.camera_file_name = stmt.ColumnText(18);
  return f;
}

absl::StatusOr<std::vector<FrameRecord>> ReadAll(Statement& stmt) {
  std::vector<FrameRecord> frames;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    ASSIGN_OR_RETURN(FrameRecord frame, ReadFrame(stmt));
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace

absl::StatusOr<CaptureRecord> FrameRepository::CaptureForJob(
    int64_t job_id, io::CaptureKind kind, absl::string_view plan) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement find,
      db.Prepare("SELECT id, session_id, kind, plan, auto_bracket FROM "
                 "captures WHERE job_id = ?1"));
  find.Bind(1, job_id);
  absl::StatusOr<bool> row = find.Step();
  if (!row.ok()) return row.status();
  if (*row) {
    ASSIGN_OR_RETURN(const io::CaptureKind found, KindOf(find.ColumnText(2)));
    return CaptureRecord{.id = find.ColumnInt(0),
                         .session_id = find.ColumnInt(1),
                         .job_id = job_id,
                         .kind = found,
                         .plan = find.ColumnText(3),
                         .auto_bracket = find.ColumnText(4)};
  }
  // A resubmitted plan continues the capture of an earlier job of the same
  // session that failed or was cancelled, keeping the frames it recorded.
  ASSIGN_OR_RETURN(Statement adopt, db.Prepare(R"sql(
UPDATE captures SET job_id = ?1 WHERE id = (
  SELECT c.id FROM captures c JOIN jobs j ON j.id = c.job_id
  WHERE c.session_id = (SELECT session_id FROM jobs WHERE id = ?1)
    AND c.kind = ?2 AND c.plan = ?3 AND j.state IN ('failed', 'cancelled')
  ORDER BY c.id DESC LIMIT 1)
RETURNING id, session_id, auto_bracket)sql"));
  adopt.Bind(1, job_id).Bind(2, io::CaptureKindName(kind)).Bind(3, plan);
  row = adopt.Step();
  if (!row.ok()) return row.status();
  if (*row) {
    CaptureRecord capture{.id = adopt.ColumnInt(0),
                          .session_id = adopt.ColumnInt(1),
                          .job_id = job_id,
                          .kind = kind,
                          .plan = std::string(plan),
                          .auto_bracket = adopt.ColumnText(2)};
    // Run the statement to its end so that the transaction can commit.
    RETURN_IF_ERROR(adopt.Step().status());
    RETURN_IF_ERROR(tx.Commit());
    return capture;
  }
  ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT INTO captures (session_id, job_id, kind, plan, create_time_ms)
SELECT session_id, id, ?2, ?3, ?4 FROM jobs WHERE id = ?1
RETURNING id, session_id)sql"));
  insert.Bind(1, job_id)
      .Bind(2, io::CaptureKindName(kind))
      .Bind(3, plan)
      .Bind(4, absl::ToUnixMillis(absl::Now()));
  row = insert.Step();
  if (!row.ok()) return row.status();
  if (!*row) return absl::NotFoundError(absl::StrCat("no job ", job_id));
  CaptureRecord capture{.id = insert.ColumnInt(0),
                        .session_id = insert.ColumnInt(1),
                        .job_id = job_id,
                        .kind = kind,
                        .plan = std::string(plan),
                        .auto_bracket = ""};
  RETURN_IF_ERROR(insert.Step().status());
  RETURN_IF_ERROR(tx.Commit());
  return capture;
}

absl::StatusOr<std::vector<FrameRecord>> FrameRepository::FramesOfCapture(
    int64_t capture_id) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(
      Statement stmt,
      store_.db().Prepare(absl::StrCat(
          kSelectFrame, "WHERE f.capture_id = ?1 ORDER BY f.sequence")));
  stmt.Bind(1, capture_id);
  return ReadAll(stmt);
}

absl::StatusOr<std::vector<FrameRecord>> FrameRepository::FramesOfJob(
    int64_t job_id) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(
      Statement stmt,
      store_.db().Prepare(absl::StrCat(
          kSelectFrame, "WHERE c.job_id = ?1 ORDER BY f.sequence")));
  stmt.Bind(1, job_id);
  return ReadAll(stmt);
}

absl::StatusOr<std::vector<FrameRecord>> FrameRepository::FramesOfSession(
    absl::string_view session, int64_t capture_id, int64_t after_id,
    int limit) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(
      Statement exists,
      store_.db().Prepare("SELECT id FROM sessions WHERE name = ?1"));
  exists.Bind(1, session);
  ASSIGN_OR_RETURN(bool row, exists.Step());
  if (!row) {
    return absl::NotFoundError(
        absl::StrCat("no session named \"", session, "\""));
  }
  const int64_t session_id = exists.ColumnInt(0);
  ASSIGN_OR_RETURN(Statement stmt, store_.db().Prepare(absl::StrCat(
                                       kSelectFrame,
                                       "WHERE c.session_id = ?1 AND (?2 = 0 OR "
                                       "f.capture_id = ?2) AND f.id > ?3 "
                                       "ORDER BY f.id LIMIT ?4")));
  stmt.Bind(1, session_id)
      .Bind(2, capture_id)
      .Bind(3, after_id)
      .Bind(4, int64_t{limit});
  return ReadAll(stmt);
}

absl::StatusOr<std::vector<CaptureRecord>> FrameRepository::CapturesOfSession(
    absl::string_view session) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt, store_.db().Prepare(R"sql(
SELECT s.id, c.id, c.session_id, coalesce(c.job_id, 0), c.kind, c.plan,
       c.auto_bracket
FROM sessions s LEFT JOIN captures c ON c.session_id = s.id
WHERE s.name = ?1 ORDER BY c.id
)sql"));
  stmt.Bind(1, session);
  std::vector<CaptureRecord> out;
  bool found = false;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    found = true;
    if (stmt.ColumnIsNull(1)) continue;  // a session without captures
    ASSIGN_OR_RETURN(const io::CaptureKind kind, KindOf(stmt.ColumnText(4)));
    out.push_back(CaptureRecord{.id = stmt.ColumnInt(1),
                                .session_id = stmt.ColumnInt(2),
                                .job_id = stmt.ColumnInt(3),
                                .kind = kind,
                                .plan = stmt.ColumnText(5),
                                .auto_bracket = stmt.ColumnText(6)});
  }
  if (!found) {
    return absl::NotFoundError(
        absl::StrCat("no session named \"", session, "\""));
  }
  return out;
}

absl::Status FrameRepository::InsertLocked(const FrameRecord& f) {
  store_.db().AssertHeld();
  ASSIGN_OR_RETURN(Statement insert, store_.db().Prepare(R"sql(
INSERT INTO frames (capture_id, sequence, view_index, stage_position_mm,
  exposure_s, pattern, inverse, format, width_px, height_px, path, sha256,
  camera_time_ms, camera_exposure_s, iso, aperture_f, camera_file_name)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16,
  ?17))sql"));
  insert.Bind(1, f.capture_id)
      .Bind(2, int64_t{f.sequence})
      .Bind(3, int64_t{f.view_index})
      .Bind(4, f.stage_position_mm)
      .Bind(5, f.exposure_s)
      .Bind(6, f.pattern)
      .Bind(7, int64_t{f.inverse ? 1 : 0})
      .Bind(8, hardware::ImageFormatName(f.format))
      .Bind(9, int64_t{f.width_px})
      .Bind(10, int64_t{f.height_px})
      .Bind(11, f.path)
      .Bind(12, f.sha256);
  if (f.camera_time_ms.has_value()) {
    insert.Bind(13, *f.camera_time_ms);
  } else {
    insert.BindNull(13);
  }
  int column = 14;
  for (const std::optional<double>& value :
       {f.camera_exposure_s, f.iso, f.aperture_f}) {
    if (value.has_value()) {
      insert.Bind(column, *value);
    } else {
      insert.BindNull(column);
    }
    ++column;
  }
  insert.Bind(17, f.camera_file_name);
  return insert.Run();
}

absl::Status FrameRepository::SetAutoBracket(int64_t capture_id,
                                             absl::string_view json) {
  Transaction tx(store_.db());
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement update,
      store_.db().Prepare(
          "UPDATE captures SET auto_bracket = ?2 WHERE id = ?1 RETURNING id"));
  update.Bind(1, capture_id).Bind(2, json);
  ASSIGN_OR_RETURN(const bool row, update.Step());
  if (!row) return absl::NotFoundError(absl::StrCat("no capture ", capture_id));
  RETURN_IF_ERROR(update.Step().status());
  return tx.Commit();
}

absl::StatusOr<std::string> FrameRepository::AutoBracketOfJob(int64_t job_id) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement find,
                   store_.db().Prepare(
                       "SELECT auto_bracket FROM captures WHERE job_id = ?1"));
  find.Bind(1, job_id);
  ASSIGN_OR_RETURN(const bool row, find.Step());
  if (!row) {
    return absl::NotFoundError(absl::StrCat("job ", job_id, " has no capture"));
  }
  return find.ColumnText(0);
}

absl::Status FrameRepository::SetProjectorTiming(
    int64_t capture_id, const ProjectorTiming& timing) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement update, store_.db().Prepare(R"sql(
UPDATE captures SET projector_latency_s = ?2, projector_refresh_hz = ?3
WHERE id = ?1 RETURNING id
)sql"));
  update.Bind(1, capture_id);
  int column = 2;
  for (const std::optional<double>& value :
       {timing.latency_s, timing.refresh_hz}) {
    if (value.has_value()) {
      update.Bind(column, *value);
    } else {
      update.BindNull(column);
    }
    ++column;
  }
  ASSIGN_OR_RETURN(const bool found, update.Step());
  if (!found) {
    return absl::NotFoundError(absl::StrCat("no capture ", capture_id));
  }
  return update.Step().status();
}

absl::StatusOr<ProjectorTiming> FrameRepository::ProjectorTimingOf(
    int64_t capture_id) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement select, store_.db().Prepare(R"sql(
SELECT projector_latency_s, projector_refresh_hz FROM captures WHERE id = ?1
)sql"));
  select.Bind(1, capture_id);
  ASSIGN_OR_RETURN(const bool found, select.Step());
  if (!found) {
    return absl::NotFoundError(absl::StrCat("no capture ", capture_id));
  }
  ProjectorTiming timing;
  if (!select.ColumnIsNull(0)) timing.latency_s = select.ColumnDouble(0);
  if (!select.ColumnIsNull(1)) timing.refresh_hz = select.ColumnDouble(1);
  return timing;
}

absl::StatusOr<int64_t> FrameRepository::CaptureIdOfJob(int64_t job_id) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(
      Statement find,
      store_.db().Prepare("SELECT id FROM captures WHERE job_id = ?1"));
  find.Bind(1, job_id);
  ASSIGN_OR_RETURN(const bool row, find.Step());
  if (!row) {
    return absl::NotFoundError(absl::StrCat("job ", job_id, " has no capture"));
  }
  return find.ColumnInt(0);
}

absl::Status FrameRepository::Delete(int64_t frame_id) {
  Transaction tx(store_.db());
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(Statement remove,
                   store_.db().Prepare("DELETE FROM frames WHERE id = ?1"));
  RETURN_IF_ERROR(remove.Bind(1, frame_id).Run());
  return tx.Commit();
}

}  // namespace hdrstereo::store
