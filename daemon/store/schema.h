// SPDX-License-Identifier: GPL-3.0-or-later
//
// The SQLite schema and its forward migrations. Each migration is applied in
// its own transaction and recorded in `schema_version`; a database written by
// a newer binary (a version this binary does not know) is refused untouched.
#ifndef HDRSTEREO_DAEMON_STORE_SCHEMA_H_
#define HDRSTEREO_DAEMON_STORE_SCHEMA_H_

#include "absl/status/statusor.h"
#include "daemon/store/database.h"

namespace hdrstereo::store {

// The newest schema version this binary knows.
int LatestSchemaVersion();

// The version recorded in `db`, 0 for an empty database. Fails with
// FAILED_PRECONDITION when the file is not a SQLite database or is corrupt.
absl::StatusOr<int> ReadSchemaVersion(Database& db)
    ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex());

// Brings `db` to `target` (tests stop at an older version to migrate from
// it), at most LatestSchemaVersion(); returns the version reached. Fails
// with FAILED_PRECONDITION, changing nothing, when the database is newer than
// this binary.
absl::StatusOr<int> Migrate(Database& db, int target = LatestSchemaVersion());

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_SCHEMA_H_
