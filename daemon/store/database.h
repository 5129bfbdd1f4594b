// SPDX-License-Identifier: GPL-3.0-or-later
//
// A thin RAII layer over the SQLite C API: one connection, prepared
// statements, transactions, and errors as absl::Status.
#ifndef HDRSTEREO_DAEMON_STORE_DATABASE_H_
#define HDRSTEREO_DAEMON_STORE_DATABASE_H_

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"

namespace hdrstereo::store {

class Database;

// A prepared statement. Bind parameters are 1-based, as in SQLite.
class Statement {
 public:
  Statement(Statement&&) noexcept;
  Statement& operator=(Statement&&) = delete;
  ~Statement();

  Statement& Bind(int index, int64_t value);
  Statement& Bind(int index, double value);
  Statement& Bind(int index, absl::string_view value);
  Statement& Bind(int index, const char* value) {
    return Bind(index, absl::string_view(value));
  }
  Statement& BindNull(int index);

  // Advances to the next row: true if a row is available, false when done.
  absl::StatusOr<bool> Step();
  // Runs a statement that returns no rows.
  absl::Status Run();

  int64_t ColumnInt(int column) const;
  double ColumnDouble(int column) const;
  std::string ColumnText(int column) const;
  bool ColumnIsNull(int column) const;

 private:
  friend class Database;
  Statement(sqlite3* db, sqlite3_stmt* stmt) : db_(db), stmt_(stmt) {}

  sqlite3* db_;
  sqlite3_stmt* stmt_;
  int bind_error_ = SQLITE_OK;
};

// One SQLite connection shared by the daemon's threads. A statement from
// another thread would silently join an open transaction on the same
// connection, so every use holds the connection's mutex: for reads
// `absl::MutexLock lock(&db.mutex());`, for writes a Transaction (which takes
// it itself). The mutex is not recursive. Clang's -Wthread-safety checks the
// callers (deploy/check-thread-safety.sh); a statement, once prepared, must
// not outlive the lock it was prepared under.
class Database {
 public:
  enum class Mode { kReadWriteCreate, kReadWrite, kReadOnly };

  static absl::StatusOr<std::unique_ptr<Database>> Open(
      const std::filesystem::path& path, Mode mode = Mode::kReadWriteCreate);
  ~Database();

  absl::StatusOr<Statement> Prepare(absl::string_view sql)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  // Runs one or more statements that take no parameters.
  absl::Status Exec(absl::string_view sql)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  int64_t LastInsertId() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  int Changes() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);

  absl::Mutex& mutex() ABSL_LOCK_RETURNED(mutex_) { return mutex_; }
  // For code that runs inside a caller's transaction through a callback,
  // where the analysis cannot follow the lock: checks at run time that the
  // mutex is held, and tells the analysis so.
  void AssertHeld() const ABSL_ASSERT_EXCLUSIVE_LOCK(mutex_) {
    mutex_.AssertHeld();
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  Database(sqlite3* db, std::filesystem::path path)
      : db_(db), path_(std::move(path)) {}

  sqlite3* const db_;
  const std::filesystem::path path_;
  mutable absl::Mutex mutex_;
};

// A write transaction: takes the database's mutex for its lifetime and runs
// BEGIN IMMEDIATE; ROLLBACK on destruction unless Commit() succeeded.
//   Transaction tx(db);
//   RETURN_IF_ERROR(tx.status());
//   ... db.Prepare(...) ...
//   RETURN_IF_ERROR(tx.Commit());
class ABSL_SCOPED_LOCKABLE Transaction {
 public:
  explicit Transaction(Database& db) ABSL_EXCLUSIVE_LOCK_FUNCTION(db.mutex());
  ~Transaction() ABSL_UNLOCK_FUNCTION();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

  // Whether BEGIN succeeded; nothing may run in a transaction that did not.
  const absl::Status& status() const { return status_; }
  absl::Status Commit();

 private:
  Database& db_;
  absl::Status status_;
  bool done_ = false;
};

// Maps a SQLite result code to a status with `context` in the message.
absl::Status SqliteStatus(int code, sqlite3* db, absl::string_view context);

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_DATABASE_H_
