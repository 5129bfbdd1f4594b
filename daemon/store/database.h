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
#include <mutex>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

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
// connection, so every use holds the connection's lock: Lock() for reads,
// Transaction (which takes the lock itself) for writes. The lock is not
// recursive.
class Database {
 public:
  enum class Mode { kReadWriteCreate, kReadWrite, kReadOnly };

  static absl::StatusOr<std::unique_ptr<Database>> Open(
      const std::filesystem::path& path, Mode mode = Mode::kReadWriteCreate);
  ~Database();

  absl::StatusOr<Statement> Prepare(absl::string_view sql);
  // Runs one or more statements that take no parameters.
  absl::Status Exec(absl::string_view sql);
  int64_t LastInsertId() const;
  int Changes() const;

  [[nodiscard]] std::unique_lock<std::mutex> Lock() {
    return std::unique_lock(mutex_);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  Database(sqlite3* db, std::filesystem::path path)
      : db_(db), path_(std::move(path)) {}

  sqlite3* db_;
  std::filesystem::path path_;
  std::mutex mutex_;
};

// Takes the database's lock and runs BEGIN IMMEDIATE; ROLLBACK on destruction
// unless Commit() succeeded.
class Transaction {
 public:
  static absl::StatusOr<std::unique_ptr<Transaction>> Begin(Database& db);
  ~Transaction();
  absl::Status Commit();

 private:
  Transaction(Database& db, std::unique_lock<std::mutex> lock)
      : db_(db), lock_(std::move(lock)) {}
  Database& db_;
  std::unique_lock<std::mutex> lock_;
  bool done_ = false;
};

// Maps a SQLite result code to a status with `context` in the message.
absl::Status SqliteStatus(int code, sqlite3* db, absl::string_view context);

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_DATABASE_H_
