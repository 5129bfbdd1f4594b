// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/session_repository.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "daemon/store/names.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

constexpr absl::string_view kSelectSession = R"sql(
SELECT s.id, s.name, s.note, s.create_time_ms,
  (SELECT count(*) FROM captures c WHERE c.session_id = s.id),
  (SELECT count(*) FROM frames f JOIN captures c ON f.capture_id = c.id
     WHERE c.session_id = s.id),
  (SELECT count(*) FROM artifacts a WHERE a.session_id = s.id)
FROM sessions s
)sql";

SessionRecord ReadSession(const Statement& stmt) {
  return SessionRecord{
      .id = stmt.ColumnInt(0),
      .name = stmt.ColumnText(1),
      .note = stmt.ColumnText(2),
      .create_time_ms = stmt.ColumnInt(3),
      .capture_count = static_cast<int>(stmt.ColumnInt(4)),
      .frame_count = static_cast<int>(stmt.ColumnInt(5)),
      .artifact_count = static_cast<int>(stmt.ColumnInt(6)),
  };
}

absl::Status NotFound(absl::string_view name) {
  return absl::NotFoundError(absl::StrCat("no session named \"", name, "\""));
}

// Reads one session; the caller holds the database lock.
absl::StatusOr<SessionRecord> GetLocked(Database& db, absl::string_view name)
    ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex()) {
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare(absl::StrCat(
                                       kSelectSession, "WHERE s.name = ?1")));
  stmt.Bind(1, name);
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) return NotFound(name);
  return ReadSession(stmt);
}

// The session's rows, in one transaction; FAILED_PRECONDITION while it has
// unfinished jobs.
absl::StatusOr<SessionRecord> DeleteRows(Database& db, absl::string_view name) {
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(SessionRecord record, GetLocked(db, name));
  ASSIGN_OR_RETURN(
      Statement active,
      db.Prepare("SELECT count(*) FROM jobs WHERE session_id = ?1 AND state IN "
                 "('queued', 'running', 'paused')"));
  active.Bind(1, record.id);
  RETURN_IF_ERROR(active.Step().status());
  if (int64_t n = active.ColumnInt(0); n > 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("session \"", name, "\" has ", n,
                     " queued, running or paused job(s); cancel them first"));
  }
  ASSIGN_OR_RETURN(Statement remove,
                   db.Prepare("DELETE FROM sessions WHERE id = ?1"));
  RETURN_IF_ERROR(remove.Bind(1, record.id).Run());
  RETURN_IF_ERROR(tx.Commit());
  return record;
}

}  // namespace

absl::StatusOr<SessionRecord> SessionRepository::Create(
    absl::string_view name, absl::string_view note) {
  RETURN_IF_ERROR(ValidateName(name, "session name"));
  if (note.size() > kMaxNoteBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("note has ", note.size(), " bytes; at most ",
                     kMaxNoteBytes, " are allowed"));
  }
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(Statement insert,
                   db.Prepare("INSERT INTO sessions (name, note, "
                              "create_time_ms) VALUES (?1, ?2, ?3)"));
  absl::Status inserted = insert.Bind(1, name)
                              .Bind(2, note)
                              .Bind(3, absl::ToUnixMillis(absl::Now()))
                              .Run();
  if (absl::IsAlreadyExists(inserted)) {
    return absl::AlreadyExistsError(
        absl::StrCat("a session named \"", name, "\" already exists"));
  }
  if (!inserted.ok()) return inserted;
  // The folder exists before the row is committed; a crash in between leaves
  // only an empty folder, which the next start moves to orphaned/.
  RETURN_IF_ERROR(store_.files().CreateSessionDir(name));
  ASSIGN_OR_RETURN(SessionRecord record, GetLocked(db, name));
  if (absl::Status s = tx.Commit(); !s.ok()) {
    store_.files().RemoveSessionDir(name).IgnoreError();
    return s;
  }
  return record;
}

absl::StatusOr<SessionRecord> SessionRepository::Get(absl::string_view name) {
  RETURN_IF_ERROR(ValidateName(name, "session name"));
  absl::MutexLock lock(&store_.db().mutex());
  return GetLocked(store_.db(), name);
}

absl::StatusOr<SessionPage> SessionRepository::List(absl::string_view after,
                                                    int limit) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(
      Statement stmt,
      store_.db().Prepare(absl::StrCat(
          kSelectSession, "WHERE s.name > ?1 ORDER BY s.name LIMIT ?2")));
  // One extra row tells whether another page follows.
  stmt.Bind(1, after).Bind(2, int64_t{limit} + 1);
  SessionPage page;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    page.sessions.push_back(ReadSession(stmt));
  }
  if (static_cast<int>(page.sessions.size()) > limit) {
    page.sessions.pop_back();
    page.next_after = page.sessions.back().name;
  }
  return page;
}

absl::StatusOr<DeletedSession> SessionRepository::Delete(
    absl::string_view name) {
  RETURN_IF_ERROR(ValidateName(name, "session name"));
  ASSIGN_OR_RETURN(SessionRecord record, DeleteRows(store_.db(), name));

  // The rows are gone; a crash while removing files leaves a folder without
  // a row, which the next start moves to orphaned/.
  if (absl::Status s = store_.files().RemoveSessionDir(name); !s.ok()) {
    return absl::InternalError(absl::StrCat(
        "session \"", name,
        "\" was deleted from the database but its folder "
        "was not removed (it moves to orphaned/ at the next start): ",
        s.message()));
  }
  return DeletedSession{.frames = record.frame_count,
                        .artifacts = record.artifact_count};
}

}  // namespace hdrstereo::store
