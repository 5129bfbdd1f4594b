// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/schedule_repository.h"

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "daemon/store/names.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

constexpr char kSelectSchedule[] =
    "SELECT s.id, s.name, s.cron, s.time_zone, s.enabled, s.plan, "
    "s.missed_run_policy, s.create_time_ms, "
    "coalesce(s.enable_time_ms, s.create_time_ms), "
    "(SELECT max(r.due_time_ms) FROM schedule_runs r "
    "WHERE r.schedule_id = s.id), s.created_by, s.enabled_by "
    "FROM schedules s ";

constexpr char kSelectRun[] =
    "SELECT r.id, r.schedule_id, s.name, r.due_time_ms, r.start_time_ms, "
    "r.end_time_ms, r.session, r.job_ids, r.outcome, r.reason, r.caused_by "
    "FROM schedule_runs r JOIN schedules s ON s.id = r.schedule_id ";

absl::Status NotFound(absl::string_view name) {
  return absl::NotFoundError(absl::StrCat("no schedule named \"", name, "\""));
}

ScheduleRecord ReadSchedule(const Statement& stmt) {
  ScheduleRecord r;
  r.id = stmt.ColumnInt(0);
  r.name = stmt.ColumnText(1);
  r.cron = stmt.ColumnText(2);
  r.time_zone = stmt.ColumnText(3);
  r.enabled = stmt.ColumnInt(4) != 0;
  r.plan = stmt.ColumnText(5);
  r.missed_run_policy = stmt.ColumnText(6) == "skip"
                            ? MissedRunPolicy::kSkip
                            : MissedRunPolicy::kRunOnceOnStart;
  r.create_time_ms = stmt.ColumnInt(7);
  r.enable_time_ms = stmt.ColumnInt(8);
  if (!stmt.ColumnIsNull(9)) r.last_due_time_ms = stmt.ColumnInt(9);
  r.created_by = stmt.ColumnText(10);
  r.enabled_by = stmt.ColumnText(11);
  return r;
}

RunOutcome ParseOutcome(const std::string& text) {
  if (text == "succeeded") return RunOutcome::kSucceeded;
  if (text == "failed") return RunOutcome::kFailed;
  if (text == "skipped") return RunOutcome::kSkipped;
  return RunOutcome::kRunning;
}

ScheduleRunRecord ReadRun(const Statement& stmt) {
  ScheduleRunRecord r;
  r.id = stmt.ColumnInt(0);
  r.schedule_id = stmt.ColumnInt(1);
  r.schedule = stmt.ColumnText(2);
  r.due_time_ms = stmt.ColumnInt(3);
  if (!stmt.ColumnIsNull(4)) r.start_time_ms = stmt.ColumnInt(4);
  if (!stmt.ColumnIsNull(5)) r.end_time_ms = stmt.ColumnInt(5);
  r.session = stmt.ColumnText(6);
  for (absl::string_view id :
       absl::StrSplit(stmt.ColumnText(7), ',', absl::SkipEmpty())) {
    int64_t value = 0;
    if (absl::SimpleAtoi(id, &value)) r.job_ids.push_back(value);
  }
  r.outcome = ParseOutcome(stmt.ColumnText(8));
  r.reason = stmt.ColumnText(9);
  r.caused_by = stmt.ColumnText(10);
  return r;
}

absl::StatusOr<ScheduleRecord> GetLocked(Database& db, absl::string_view name)
    ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex()) {
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare(absl::StrCat(
                                       kSelectSchedule, "WHERE s.name = ?1")));
  stmt.Bind(1, name);
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) return NotFound(name);
  return ReadSchedule(stmt);
}

Statement& BindOptional(Statement& stmt, int index,
                        const std::optional<int64_t>& value) {
  return value ? stmt.Bind(index, *value) : stmt.BindNull(index);
}

}  // namespace

const char* RunOutcomeName(RunOutcome outcome) {
  switch (outcome) {
    case RunOutcome::kRunning:
      return "running";
    case RunOutcome::kSucceeded:
      return "succeeded";
    case RunOutcome::kFailed:
      return "failed";
    case RunOutcome::kSkipped:
      return "skipped";
  }
  return "running";
}

absl::StatusOr<ScheduleRecord> ScheduleRepository::Create(
    const ScheduleRecord& schedule, int64_t now_ms) {
  RETURN_IF_ERROR(ValidateName(schedule.name, "schedule name"));
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement insert,
      db.Prepare(
          "INSERT INTO schedules (name, cron, time_zone, enabled, plan, "
          "missed_run_policy, create_time_ms, enable_time_ms, created_by, "
          "enabled_by) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?7, ?8, ?8)"));
  absl::Status inserted =
      insert.Bind(1, schedule.name)
          .Bind(2, schedule.cron)
          .Bind(3, schedule.time_zone)
          .Bind(4, int64_t{schedule.enabled ? 1 : 0})
          .Bind(5, schedule.plan)
          .Bind(6, schedule.missed_run_policy == MissedRunPolicy::kSkip
                       ? "skip"
                       : "run_once_on_start")
          .Bind(7, now_ms)
          .Bind(8, schedule.created_by)
          .Run();
  if (absl::IsAlreadyExists(inserted)) {
    return absl::AlreadyExistsError(absl::StrCat(
        "a schedule named \"", schedule.name, "\" already exists"));
  }
  if (!inserted.ok()) return inserted;
  ASSIGN_OR_RETURN(ScheduleRecord record, GetLocked(db, schedule.name));
  RETURN_IF_ERROR(tx.Commit());
  return record;
}

absl::StatusOr<ScheduleRecord> ScheduleRepository::Get(absl::string_view name) {
  absl::MutexLock lock(&store_.db().mutex());
  return GetLocked(store_.db(), name);
}

absl::StatusOr<std::vector<ScheduleRecord>> ScheduleRepository::List(
    absl::string_view after, int limit) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(
      Statement stmt,
      store_.db().Prepare(absl::StrCat(
          kSelectSchedule, "WHERE s.name > ?1 ORDER BY s.name LIMIT ?2")));
  stmt.Bind(1, after).Bind(2, int64_t{limit});
  std::vector<ScheduleRecord> out;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    out.push_back(ReadSchedule(stmt));
  }
  return out;
}

absl::Status ScheduleRepository::Delete(absl::string_view name) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(Statement stmt,
                   db.Prepare("DELETE FROM schedules WHERE name = ?1"));
  RETURN_IF_ERROR(stmt.Bind(1, name).Run());
  if (db.Changes() == 0) return NotFound(name);
  return tx.Commit();
}

absl::StatusOr<ScheduleRecord> ScheduleRepository::SetEnabled(
    absl::string_view name, bool enabled, int64_t now_ms,
    absl::string_view by) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(ScheduleRecord current, GetLocked(db, name));
  if (current.enabled != enabled) {
    ASSIGN_OR_RETURN(
        Statement stmt,
        db.Prepare(
            enabled ? "UPDATE schedules SET enabled = 1, enable_time_ms = ?2, "
                      "enabled_by = ?3 WHERE id = ?1"
                    : "UPDATE schedules SET enabled = 0 WHERE id = ?1"));
    stmt.Bind(1, current.id);
    if (enabled) stmt.Bind(2, now_ms).Bind(3, by);
    RETURN_IF_ERROR(stmt.Run());
  }
  ASSIGN_OR_RETURN(ScheduleRecord record, GetLocked(db, name));
  RETURN_IF_ERROR(tx.Commit());
  return record;
}

absl::StatusOr<ScheduleRunRecord> ScheduleRepository::AddRun(
    const ScheduleRunRecord& run) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement stmt,
      db.Prepare(
          "INSERT INTO schedule_runs (schedule_id, due_time_ms, start_time_ms, "
          "end_time_ms, session, job_ids, outcome, reason, caused_by, "
          "announced) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, 0)"));
  stmt.Bind(1, run.schedule_id).Bind(2, run.due_time_ms);
  BindOptional(stmt, 3, run.start_time_ms);
  BindOptional(stmt, 4, run.end_time_ms);
  stmt.Bind(5, run.session)
      .Bind(6, absl::StrJoin(run.job_ids, ","))
      .Bind(7, RunOutcomeName(run.outcome))
      .Bind(8, run.reason)
      .Bind(9, run.caused_by);
  RETURN_IF_ERROR(stmt.Run());
  ScheduleRunRecord out = run;
  out.id = db.LastInsertId();
  RETURN_IF_ERROR(tx.Commit());
  return out;
}

absl::Status ScheduleRepository::UpdateRun(const ScheduleRunRecord& run) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement stmt,
      db.Prepare(
          "UPDATE schedule_runs SET start_time_ms = ?2, end_time_ms = ?3, "
          "session = ?4, job_ids = ?5, outcome = ?6, reason = ?7 WHERE id = "
          "?1"));
  stmt.Bind(1, run.id);
  BindOptional(stmt, 2, run.start_time_ms);
  BindOptional(stmt, 3, run.end_time_ms);
  stmt.Bind(4, run.session)
      .Bind(5, absl::StrJoin(run.job_ids, ","))
      .Bind(6, RunOutcomeName(run.outcome))
      .Bind(7, run.reason);
  RETURN_IF_ERROR(stmt.Run());
  return tx.Commit();
}

absl::StatusOr<std::vector<ScheduleRunRecord>> ScheduleRepository::Runs(
    absl::string_view name, int64_t before_due_ms, int limit) {
  absl::MutexLock lock(&store_.db().mutex());
  RETURN_IF_ERROR(GetLocked(store_.db(), name).status());
  ASSIGN_OR_RETURN(Statement stmt,
                   store_.db().Prepare(absl::StrCat(
                       kSelectRun,
                       "WHERE s.name = ?1 AND (?2 = 0 OR r.due_time_ms < ?2) "
                       "ORDER BY r.due_time_ms DESC LIMIT ?3")));
  stmt.Bind(1, name).Bind(2, before_due_ms).Bind(3, int64_t{limit});
  std::vector<ScheduleRunRecord> out;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    out.push_back(ReadRun(stmt));
  }
  return out;
}

absl::StatusOr<std::vector<ScheduleRunRecord>>
ScheduleRepository::RunningRuns() {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(
      Statement stmt,
      store_.db().Prepare(absl::StrCat(
          kSelectRun, "WHERE r.outcome = 'running' ORDER BY r.id")));
  std::vector<ScheduleRunRecord> out;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    out.push_back(ReadRun(stmt));
  }
  return out;
}

absl::StatusOr<std::vector<ScheduleRunRecord>>
ScheduleRepository::UnannouncedRuns(int limit) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt,
                   store_.db().Prepare(absl::StrCat(
                       kSelectRun,
                       "WHERE r.announced = 0 AND r.outcome != 'running' "
                       "ORDER BY r.id LIMIT ?1")));
  stmt.Bind(1, int64_t{limit});
  std::vector<ScheduleRunRecord> out;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    out.push_back(ReadRun(stmt));
  }
  return out;
}

}  // namespace hdrstereo::store
