// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/calibration_repository.h"

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "daemon/store/database.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

// Per-pose errors as text: "0.12,0.09,...".
std::string JoinErrors(const std::vector<double>& values) {
  return absl::StrJoin(
      values, ",", [](std::string* out, double v) { absl::StrAppend(out, v); });
}

std::vector<double> SplitErrors(const std::string& text) {
  std::vector<double> values;
  for (absl::string_view part : absl::StrSplit(text, ',', absl::SkipEmpty())) {
    double v = 0;
    if (absl::SimpleAtod(part, &v)) values.push_back(v);
  }
  return values;
}

}  // namespace

absl::StatusOr<int64_t> CalibrationRepository::Insert(
    const CalibrationRecord& record) {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT INTO rig_calibrations (capture_id, job_id, dir, poses, rms_stereo,
                              rms_left, rms_right, coverage_left,
                              coverage_right, create_time_ms)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10) RETURNING id)sql"));
  insert.Bind(1, record.capture_id)
      .Bind(2, record.job_id)
      .Bind(3, record.dir)
      .Bind(4, int64_t{record.poses})
      .Bind(5, record.rms_stereo)
      .Bind(6, JoinErrors(record.rms_left))
      .Bind(7, JoinErrors(record.rms_right))
      .Bind(8, record.coverage_left)
      .Bind(9, record.coverage_right)
      .Bind(10, absl::ToUnixMillis(absl::Now()));
  ASSIGN_OR_RETURN(bool row, insert.Step());
  if (!row)
    return absl::InternalError("inserting a calibration returned no id");
  return insert.ColumnInt(0);
}

absl::StatusOr<std::optional<CalibrationRecord>>
CalibrationRepository::Latest() {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare(R"sql(
SELECT r.id, r.capture_id, s.name, r.job_id, r.dir, r.poses, r.rms_stereo,
       r.rms_left, r.rms_right, r.coverage_left, r.coverage_right,
       r.create_time_ms
FROM rig_calibrations r
JOIN captures c ON c.id = r.capture_id
JOIN sessions s ON s.id = c.session_id
ORDER BY r.id DESC LIMIT 1)sql"));
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) return std::nullopt;
  CalibrationRecord r;
  r.id = stmt.ColumnInt(0);
  r.capture_id = stmt.ColumnInt(1);
  r.session = stmt.ColumnText(2);
  r.job_id = stmt.ColumnInt(3);
  r.dir = stmt.ColumnText(4);
  r.poses = static_cast<int>(stmt.ColumnInt(5));
  r.rms_stereo = stmt.ColumnDouble(6);
  r.rms_left = SplitErrors(stmt.ColumnText(7));
  r.rms_right = SplitErrors(stmt.ColumnText(8));
  r.coverage_left = stmt.ColumnDouble(9);
  r.coverage_right = stmt.ColumnDouble(10);
  r.create_time_ms = stmt.ColumnInt(11);
  return r;
}

}  // namespace hdrstereo::store
