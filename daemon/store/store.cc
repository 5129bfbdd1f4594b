// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/store.h"

#include <set>
#include <string>

#include "absl/strings/str_cat.h"
#include "daemon/store/schema.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

absl::StatusOr<std::set<std::string>> SessionNames(Database& db) {
  absl::MutexLock lock(&db.mutex());
  ASSIGN_OR_RETURN(Statement stmt, db.Prepare("SELECT name FROM sessions"));
  std::set<std::string> names;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    names.insert(stmt.ColumnText(0));
  }
  return names;
}

// The first real read of a file that is not a database fails here, before
// anything was written to it.
absl::Status CheckReadable(Database& db) {
  absl::MutexLock lock(&db.mutex());
  absl::StatusOr<Statement> stmt = db.Prepare("PRAGMA quick_check");
  if (!stmt.ok()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "database ", db.path().string(),
        " is corrupt or not a SQLite file: ", stmt.status().message()));
  }
  absl::StatusOr<bool> row = stmt->Step();
  if (!row.ok() || !*row || stmt->ColumnText(0) != "ok") {
    return absl::FailedPreconditionError(absl::StrCat(
        "database ", db.path().string(), " is corrupt or not a SQLite file: ",
        row.ok() ? stmt->ColumnText(0) : row.status().message()));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::unique_ptr<Store>> Store::Open(
    const std::filesystem::path& data_root) {
  ASSIGN_OR_RETURN(FileStore files, FileStore::Open(data_root));

  ASSIGN_OR_RETURN(std::unique_ptr<Database> db,
                   Database::Open(files.database_path()));
  RETURN_IF_ERROR(CheckReadable(*db));
  // Migrate refuses a newer database before anything is written to it.
  ASSIGN_OR_RETURN(int version, Migrate(*db));
  {
    // WAL lets readers (the sqlite3 shell, backups) run beside the daemon;
    // synchronous=FULL makes each committed frame row survive a power cut.
    absl::MutexLock lock(&db->mutex());
    if (absl::Status s =
            db->Exec("PRAGMA journal_mode = WAL; PRAGMA synchronous = FULL; "
                     "PRAGMA foreign_keys = ON;");
        !s.ok()) {
      return s;
    }
  }

  ASSIGN_OR_RETURN(std::set<std::string> names, SessionNames(*db));
  RETURN_IF_ERROR(files.Sweep(names).status());
  return std::unique_ptr<Store>(
      new Store(std::move(db), std::move(files), version));
}

}  // namespace hdrstereo::store
