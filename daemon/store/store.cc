// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/store.h"

#include <set>
#include <string>

#include "absl/strings/str_cat.h"
#include "daemon/store/schema.h"

namespace hdrstereo::store {
namespace {

absl::StatusOr<std::set<std::string>> SessionNames(Database& db) {
  std::unique_lock<std::mutex> lock = db.Lock();
  absl::StatusOr<Statement> stmt = db.Prepare("SELECT name FROM sessions");
  if (!stmt.ok()) return stmt.status();
  std::set<std::string> names;
  while (true) {
    absl::StatusOr<bool> row = stmt->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    names.insert(stmt->ColumnText(0));
  }
  return names;
}

// The first real read of a file that is not a database fails here, before
// anything was written to it.
absl::Status CheckReadable(Database& db) {
  std::unique_lock<std::mutex> lock = db.Lock();
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
  absl::StatusOr<FileStore> files = FileStore::Open(data_root);
  if (!files.ok()) return files.status();

  absl::StatusOr<std::unique_ptr<Database>> db =
      Database::Open(files->database_path());
  if (!db.ok()) return db.status();
  if (absl::Status s = CheckReadable(**db); !s.ok()) return s;
  // Migrate refuses a newer database before anything is written to it.
  absl::StatusOr<int> version = Migrate(**db);
  if (!version.ok()) return version.status();
  {
    // WAL lets readers (the sqlite3 shell, backups) run beside the daemon;
    // synchronous=FULL makes each committed frame row survive a power cut.
    std::unique_lock<std::mutex> lock = (*db)->Lock();
    if (absl::Status s =
            (*db)->Exec("PRAGMA journal_mode = WAL; PRAGMA synchronous = FULL; "
                        "PRAGMA foreign_keys = ON;");
        !s.ok()) {
      return s;
    }
  }

  absl::StatusOr<std::set<std::string>> names = SessionNames(**db);
  if (!names.ok()) return names.status();
  if (absl::StatusOr<int> swept = files->Sweep(*names); !swept.ok()) {
    return swept.status();
  }
  return std::unique_ptr<Store>(
      new Store(*std::move(db), *std::move(files), *version));
}

}  // namespace hdrstereo::store
