// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/artifact_repository.h"

#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

constexpr absl::string_view kSelectArtifact = R"sql(
SELECT a.id, coalesce(a.job_id, 0), a.step, a.kind, a.path, a.params_json,
  a.params_hash, a.sha256, a.size_bytes, a.create_time_ms
FROM artifacts a
)sql";

ArtifactRecord ReadArtifact(const Statement& stmt) {
  return ArtifactRecord{
      .id = stmt.ColumnInt(0),
      .job_id = stmt.ColumnInt(1),
      .step = stmt.ColumnText(2),
      .kind = stmt.ColumnText(3),
      .path = stmt.ColumnText(4),
      .params_json = stmt.ColumnText(5),
      .params_hash = stmt.ColumnText(6),
      .sha256 = stmt.ColumnText(7),
      .size_bytes = stmt.ColumnInt(8),
      .create_time_ms = stmt.ColumnInt(9),
  };
}

absl::StatusOr<std::vector<ArtifactRecord>> ReadAll(Statement& stmt) {
  std::vector<ArtifactRecord> out;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) return out;
    out.push_back(ReadArtifact(stmt));
  }
}

// The caller holds the database lock.
absl::StatusOr<int64_t> SessionIdLocked(Database& db, absl::string_view session)
    ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex()) {
  ASSIGN_OR_RETURN(Statement stmt,
                   db.Prepare("SELECT id FROM sessions WHERE name = ?1"));
  stmt.Bind(1, session);
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) {
    return absl::NotFoundError(
        absl::StrCat("no session named \"", session, "\""));
  }
  return stmt.ColumnInt(0);
}

void BindJob(Statement& stmt, int index, int64_t job_id) {
  if (job_id > 0) {
    stmt.Bind(index, job_id);
  } else {
    stmt.BindNull(index);
  }
}

}  // namespace

absl::StatusOr<std::vector<ArtifactRecord>> ArtifactRepository::ForStep(
    int64_t session_id, absl::string_view step, absl::string_view params_hash) {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(
      Statement stmt,
      db.Prepare(absl::StrCat(
          kSelectArtifact,
          "WHERE a.session_id = ?1 AND a.step = ?2 AND a.params_hash = ?3 "
          "ORDER BY a.id")));
  stmt.Bind(1, session_id).Bind(2, step).Bind(3, params_hash);
  return ReadAll(stmt);
}

absl::Status ArtifactRepository::ReplaceStep(
    int64_t session_id, int64_t job_id, absl::string_view step,
    const std::vector<ArtifactRecord>& artifacts) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement clear,
      db.Prepare("DELETE FROM artifacts WHERE session_id = ?1 AND step = ?2"));
  RETURN_IF_ERROR(clear.Bind(1, session_id).Bind(2, step).Run());
  const int64_t now = absl::ToUnixMillis(absl::Now());
  for (const ArtifactRecord& a : artifacts) {
    // A path written by another step before (a renamed step, say) now
    // belongs to this one.
    ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT INTO artifacts (session_id, job_id, step, kind, path, params_json,
  params_hash, sha256, size_bytes, create_time_ms)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)
ON CONFLICT (session_id, path) DO UPDATE SET job_id = excluded.job_id,
  step = excluded.step, kind = excluded.kind,
  params_json = excluded.params_json, params_hash = excluded.params_hash,
  sha256 = excluded.sha256, size_bytes = excluded.size_bytes,
  create_time_ms = excluded.create_time_ms
)sql"));
    insert.Bind(1, session_id);
    BindJob(insert, 2, job_id);
    insert.Bind(3, step)
        .Bind(4, a.kind)
        .Bind(5, a.path)
        .Bind(6, a.params_json)
        .Bind(7, a.params_hash)
        .Bind(8, a.sha256)
        .Bind(9, a.size_bytes)
        .Bind(10, now);
    RETURN_IF_ERROR(insert.Run());
  }
  return tx.Commit();
}

absl::StatusOr<std::vector<ArtifactRecord>> ArtifactRepository::List(
    absl::string_view session, absl::string_view kind, int64_t after_id,
    int limit) {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(int64_t session_id, SessionIdLocked(db, session));
  ASSIGN_OR_RETURN(
      Statement stmt,
      db.Prepare(absl::StrCat(
          kSelectArtifact,
          "WHERE a.session_id = ?1 AND (?2 = '' OR a.kind = ?2) AND a.id > ?3 "
          "ORDER BY a.id LIMIT ?4")));
  stmt.Bind(1, session_id)
      .Bind(2, kind)
      .Bind(3, after_id)
      .Bind(4, int64_t{limit});
  return ReadAll(stmt);
}

absl::StatusOr<ArtifactRecord> ArtifactRepository::Get(
    absl::string_view session, int64_t artifact_id) {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(int64_t session_id, SessionIdLocked(db, session));
  ASSIGN_OR_RETURN(
      Statement stmt,
      db.Prepare(absl::StrCat(kSelectArtifact,
                              "WHERE a.session_id = ?1 AND a.id = ?2")));
  stmt.Bind(1, session_id).Bind(2, artifact_id);
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) {
    return absl::NotFoundError(absl::StrCat(
        "session \"", session, "\" has no artifact ", artifact_id));
  }
  return ReadArtifact(stmt);
}

absl::Status ArtifactRepository::ReplaceMetrics(
    int64_t session_id, int64_t job_id,
    const std::vector<MetricRecord>& metrics) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(Statement clear,
                   db.Prepare("DELETE FROM metrics WHERE session_id = ?1"));
  RETURN_IF_ERROR(clear.Bind(1, session_id).Run());
  const int64_t now = absl::ToUnixMillis(absl::Now());
  for (const MetricRecord& m : metrics) {
    ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT INTO metrics (session_id, job_id, method, ground_truth, rmse, mae,
  bad_0_5, bad_1, bad_2, bad_4, coverage, create_time_ms)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)
)sql"));
    insert.Bind(1, session_id);
    BindJob(insert, 2, job_id);
    insert.Bind(3, m.method)
        .Bind(4, m.ground_truth)
        .Bind(5, m.rmse)
        .Bind(6, m.mae)
        .Bind(7, m.bad_0_5)
        .Bind(8, m.bad_1)
        .Bind(9, m.bad_2)
        .Bind(10, m.bad_4)
        .Bind(11, m.coverage)
        .Bind(12, now);
    RETURN_IF_ERROR(insert.Run());
  }
  return tx.Commit();
}

absl::StatusOr<std::vector<MetricRecord>> ArtifactRepository::Metrics(
    int64_t session_id) {
  Database& db = store_.db();
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare(R"sql(
SELECT method, ground_truth, rmse, mae, bad_0_5, bad_1, bad_2, bad_4,
  coverage, coalesce(job_id, 0)
FROM metrics WHERE session_id = ?1
ORDER BY ground_truth, rmse IS NULL, rmse, method
)sql"));
  stmt.Bind(1, session_id);
  std::vector<MetricRecord> out;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) return out;
    // SQLite stores a NaN (a metric that could not be computed) as NULL;
    // it reads back as NaN, not as a perfect 0.
    auto metric = [&](int column) {
      return stmt.ColumnIsNull(column)
                 ? std::numeric_limits<double>::quiet_NaN()
                 : stmt.ColumnDouble(column);
    };
    out.push_back(MetricRecord{.method = stmt.ColumnText(0),
                               .ground_truth = stmt.ColumnText(1),
                               .rmse = metric(2),
                               .mae = metric(3),
                               .bad_0_5 = metric(4),
                               .bad_1 = metric(5),
                               .bad_2 = metric(6),
                               .bad_4 = metric(7),
                               .coverage = metric(8),
                               .job_id = stmt.ColumnInt(9)});
  }
}

}  // namespace hdrstereo::store
