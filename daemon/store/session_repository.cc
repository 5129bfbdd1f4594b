// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/session_repository.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "daemon/store/names.h"

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
absl::StatusOr<SessionRecord> GetLocked(Database& db, absl::string_view name) {
  absl::StatusOr<Statement> stmt =
      db.Prepare(absl::StrCat(kSelectSession, "WHERE s.name = ?1"));
  if (!stmt.ok()) return stmt.status();
  stmt->Bind(1, name);
  absl::StatusOr<bool> row = stmt->Step();
  if (!row.ok()) return row.status();
  if (!*row) return NotFound(name);
  return ReadSession(*stmt);
}

}  // namespace

absl::StatusOr<SessionRecord> SessionRepository::Create(
    absl::string_view name, absl::string_view note) {
  if (absl::Status s = ValidateName(name, "session name"); !s.ok()) return s;
  if (note.size() > kMaxNoteBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("note has ", note.size(), " bytes; at most ",
                     kMaxNoteBytes, " are allowed"));
  }
  Database& db = store_.db();
  absl::StatusOr<std::unique_ptr<Transaction>> tx = Transaction::Begin(db);
  if (!tx.ok()) return tx.status();
  absl::StatusOr<Statement> insert = db.Prepare(
      "INSERT INTO sessions (name, note, create_time_ms) VALUES (?1, ?2, ?3)");
  if (!insert.ok()) return insert.status();
  absl::Status inserted = insert->Bind(1, name)
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
  if (absl::Status s = store_.files().CreateSessionDir(name); !s.ok()) {
    return s;
  }
  absl::StatusOr<SessionRecord> record = GetLocked(db, name);
  if (!record.ok()) return record.status();
  if (absl::Status s = (*tx)->Commit(); !s.ok()) {
    store_.files().RemoveSessionDir(name).IgnoreError();
    return s;
  }
  return record;
}

absl::StatusOr<SessionRecord> SessionRepository::Get(absl::string_view name) {
  if (absl::Status s = ValidateName(name, "session name"); !s.ok()) return s;
  std::unique_lock<std::mutex> lock = store_.db().Lock();
  return GetLocked(store_.db(), name);
}

absl::StatusOr<SessionPage> SessionRepository::List(absl::string_view after,
                                                    int limit) {
  std::unique_lock<std::mutex> lock = store_.db().Lock();
  absl::StatusOr<Statement> stmt = store_.db().Prepare(absl::StrCat(
      kSelectSession, "WHERE s.name > ?1 ORDER BY s.name LIMIT ?2"));
  if (!stmt.ok()) return stmt.status();
  // One extra row tells whether another page follows.
  stmt->Bind(1, after).Bind(2, int64_t{limit} + 1);
  SessionPage page;
  while (true) {
    absl::StatusOr<bool> row = stmt->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    page.sessions.push_back(ReadSession(*stmt));
  }
  if (static_cast<int>(page.sessions.size()) > limit) {
    page.sessions.pop_back();
    page.next_after = page.sessions.back().name;
  }
  return page;
}

absl::StatusOr<DeletedSession> SessionRepository::Delete(
    absl::string_view name) {
  if (absl::Status s = ValidateName(name, "session name"); !s.ok()) return s;
  Database& db = store_.db();
  absl::StatusOr<std::unique_ptr<Transaction>> tx = Transaction::Begin(db);
  if (!tx.ok()) return tx.status();
  absl::StatusOr<SessionRecord> record = GetLocked(db, name);
  if (!record.ok()) return record.status();

  absl::StatusOr<Statement> active = db.Prepare(
      "SELECT count(*) FROM jobs WHERE session_id = ?1 AND state IN "
      "('queued', 'running', 'paused')");
  if (!active.ok()) return active.status();
  active->Bind(1, record->id);
  if (absl::StatusOr<bool> row = active->Step(); !row.ok()) {
    return row.status();
  }
  if (int64_t n = active->ColumnInt(0); n > 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("session \"", name, "\" has ", n,
                     " queued, running or paused job(s); cancel them first"));
  }
  absl::StatusOr<Statement> remove =
      db.Prepare("DELETE FROM sessions WHERE id = ?1");
  if (!remove.ok()) return remove.status();
  if (absl::Status s = remove->Bind(1, record->id).Run(); !s.ok()) return s;
  if (absl::Status s = (*tx)->Commit(); !s.ok()) return s;
  tx->reset();

  // The rows are gone; a crash while removing files leaves a folder without
  // a row, which the next start moves to orphaned/.
  if (absl::Status s = store_.files().RemoveSessionDir(name); !s.ok()) {
    return absl::InternalError(absl::StrCat(
        "session \"", name,
        "\" was deleted from the database but its folder "
        "was not removed (it moves to orphaned/ at the next start): ",
        s.message()));
  }
  return DeletedSession{.frames = record->frame_count,
                        .artifacts = record->artifact_count};
}

}  // namespace hdrstereo::store
