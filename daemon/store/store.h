// SPDX-License-Identifier: GPL-3.0-or-later
//
// The daemon's persistent state: the SQLite database and the file tree of
// one data root, opened and checked together.
#ifndef HDRSTEREO_DAEMON_STORE_STORE_H_
#define HDRSTEREO_DAEMON_STORE_STORE_H_

#include <filesystem>
#include <memory>

#include "absl/status/statusor.h"
#include "daemon/store/database.h"
#include "daemon/store/file_store.h"

namespace hdrstereo::store {

class Store {
 public:
  // Opens (creating if needed) the data root and its database, refuses a
  // corrupt database or one newer than this binary without changing it,
  // migrates an older one, and sweeps leftovers of a crash (see FileStore).
  static absl::StatusOr<std::unique_ptr<Store>> Open(
      const std::filesystem::path& data_root);

  Database& db() { return *db_; }
  FileStore& files() { return files_; }
  int schema_version() const { return schema_version_; }

 private:
  Store(std::unique_ptr<Database> db, FileStore files, int schema_version)
      : db_(std::move(db)),
        files_(std::move(files)),
        schema_version_(schema_version) {}

  std::unique_ptr<Database> db_;
  FileStore files_;
  int schema_version_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_STORE_H_
