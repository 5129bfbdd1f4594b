// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/rig_lock_repository.h"

#include "processing/base/status_macros.h"

namespace hdrstereo::store {

absl::StatusOr<std::optional<RigLockRecord>> RigLockRepository::Get() {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(
      Statement stmt,
      store_.db().Prepare("SELECT holder, note, lock_time_ms, expire_time_ms "
                          "FROM rig_lock WHERE id = 1"));
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) return std::optional<RigLockRecord>();
  return std::optional<RigLockRecord>(
      RigLockRecord{.holder = stmt.ColumnText(0),
                    .note = stmt.ColumnText(1),
                    .lock_time_ms = stmt.ColumnInt(2),
                    .expire_time_ms = stmt.ColumnInt(3)});
}

absl::Status RigLockRepository::Put(const RigLockRecord& record) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement stmt,
      db.Prepare("INSERT OR REPLACE INTO rig_lock (id, holder, note, "
                 "lock_time_ms, expire_time_ms) VALUES (1, ?1, ?2, ?3, ?4)"));
  RETURN_IF_ERROR(stmt.Bind(1, record.holder)
                      .Bind(2, record.note)
                      .Bind(3, record.lock_time_ms)
                      .Bind(4, record.expire_time_ms)
                      .Run());
  return tx.Commit();
}

absl::Status RigLockRepository::Clear() {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  RETURN_IF_ERROR(db.Exec("DELETE FROM rig_lock"));
  return tx.Commit();
}

}  // namespace hdrstereo::store
