// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/audit_repository.h"

#include "processing/base/status_macros.h"

namespace hdrstereo::store {

absl::Status AuditRepository::Append(const std::vector<AuditRecord>& records) {
  if (records.empty()) return absl::OkStatus();
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  for (const AuditRecord& r : records) {
    ASSIGN_OR_RETURN(
        Statement insert,
        db.Prepare("INSERT INTO audit (time_ms, principal, role, auth_method, "
                   "peer, method, subject, status_code, message, transport) "
                   "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)"));
    RETURN_IF_ERROR(insert.Bind(1, r.time_ms)
                        .Bind(2, r.principal)
                        .Bind(3, r.role)
                        .Bind(4, r.auth_method)
                        .Bind(5, r.peer)
                        .Bind(6, r.method)
                        .Bind(7, r.subject)
                        .Bind(8, int64_t{r.status_code})
                        .Bind(9, r.message)
                        .Bind(10, r.transport)
                        .Run());
  }
  return tx.Commit();
}

absl::StatusOr<std::vector<AuditRecord>> AuditRepository::List(
    const AuditFilter& filter) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt, store_.db().Prepare(R"sql(
SELECT id, time_ms, principal, role, auth_method, peer, method, subject,
       status_code, message, transport
FROM audit
WHERE (?1 = '' OR principal = ?1) AND (?2 = '' OR instr(method, ?2) > 0)
  AND (?3 = 0 OR time_ms >= ?3) AND (?4 = 0 OR time_ms < ?4)
  AND (?5 = 0 OR id < ?5)
ORDER BY id DESC LIMIT ?6)sql"));
  stmt.Bind(1, filter.principal)
      .Bind(2, filter.method)
      .Bind(3, filter.start_ms)
      .Bind(4, filter.end_ms)
      .Bind(5, filter.before_id)
      .Bind(6, int64_t{filter.limit});
  std::vector<AuditRecord> out;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    out.push_back({.id = stmt.ColumnInt(0),
                   .time_ms = stmt.ColumnInt(1),
                   .principal = stmt.ColumnText(2),
                   .role = stmt.ColumnText(3),
                   .auth_method = stmt.ColumnText(4),
                   .transport = stmt.ColumnText(10),
                   .peer = stmt.ColumnText(5),
                   .method = stmt.ColumnText(6),
                   .subject = stmt.ColumnText(7),
                   .status_code = static_cast<int>(stmt.ColumnInt(8)),
                   .message = stmt.ColumnText(9)});
  }
  return out;
}

}  // namespace hdrstereo::store
