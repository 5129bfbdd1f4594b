// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/api_key_repository.h"

#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

constexpr char kSelect[] =
    "SELECT id, salt, digest, user, role, note, created_by, create_time_ms, "
    "expire_time_ms, last_used_time_ms, revoke_time_ms, revoked_by "
    "FROM api_keys ";

ApiKeyRecord Read(const Statement& stmt) {
  ApiKeyRecord k;
  k.id = stmt.ColumnText(0);
  k.salt_hex = stmt.ColumnText(1);
  k.digest_hex = stmt.ColumnText(2);
  k.user = stmt.ColumnText(3);
  k.role = stmt.ColumnText(4);
  k.note = stmt.ColumnText(5);
  k.created_by = stmt.ColumnText(6);
  k.create_time_ms = stmt.ColumnInt(7);
  k.expire_time_ms = stmt.ColumnInt(8);
  if (!stmt.ColumnIsNull(9)) k.last_used_time_ms = stmt.ColumnInt(9);
  if (!stmt.ColumnIsNull(10)) k.revoke_time_ms = stmt.ColumnInt(10);
  k.revoked_by = stmt.ColumnText(11);
  return k;
}

absl::StatusOr<ApiKeyRecord> GetLocked(Database& db, absl::string_view id)
    ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex()) {
  ASSIGN_OR_RETURN(Statement stmt,
                   db.Prepare(absl::StrCat(kSelect, "WHERE id = ?1")));
  stmt.Bind(1, id);
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) return absl::NotFoundError(absl::StrCat("no API key ", id));
  return Read(stmt);
}

}  // namespace

absl::Status ApiKeyRepository::Insert(const ApiKeyRecord& key) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement insert,
      db.Prepare("INSERT INTO api_keys (id, salt, digest, user, role, note, "
                 "created_by, create_time_ms, expire_time_ms) "
                 "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)"));
  RETURN_IF_ERROR(insert.Bind(1, key.id)
                      .Bind(2, key.salt_hex)
                      .Bind(3, key.digest_hex)
                      .Bind(4, key.user)
                      .Bind(5, key.role)
                      .Bind(6, key.note)
                      .Bind(7, key.created_by)
                      .Bind(8, key.create_time_ms)
                      .Bind(9, key.expire_time_ms)
                      .Run());
  return tx.Commit();
}

absl::StatusOr<std::vector<ApiKeyRecord>> ApiKeyRepository::All() {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt,
                   store_.db().Prepare(
                       absl::StrCat(kSelect, "ORDER BY create_time_ms, id")));
  std::vector<ApiKeyRecord> keys;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    keys.push_back(Read(stmt));
  }
  return keys;
}

absl::StatusOr<ApiKeyRecord> ApiKeyRepository::Revoke(absl::string_view id,
                                                      int64_t now_ms,
                                                      absl::string_view by) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(ApiKeyRecord key, GetLocked(db, id));
  if (key.revoke_time_ms.has_value()) {
    return absl::FailedPreconditionError(
        absl::StrCat("API key ", id, " is already revoked"));
  }
  ASSIGN_OR_RETURN(Statement update,
                   db.Prepare("UPDATE api_keys SET revoke_time_ms = ?2, "
                              "revoked_by = ?3 WHERE id = ?1"));
  RETURN_IF_ERROR(update.Bind(1, id).Bind(2, now_ms).Bind(3, by).Run());
  ASSIGN_OR_RETURN(key, GetLocked(db, id));
  RETURN_IF_ERROR(tx.Commit());
  return key;
}

absl::Status ApiKeyRepository::SetLastUsed(absl::string_view id,
                                           int64_t time_ms) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement update,
      db.Prepare("UPDATE api_keys SET last_used_time_ms = ?2 WHERE id = ?1"));
  RETURN_IF_ERROR(update.Bind(1, id).Bind(2, time_ms).Run());
  return tx.Commit();
}

}  // namespace hdrstereo::store
