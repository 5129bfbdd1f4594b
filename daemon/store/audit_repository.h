// SPDX-License-Identifier: GPL-3.0-or-later
//
// The audit log (table `audit`): one row per audited call. Rows are only
// ever appended.
#ifndef HDRSTEREO_DAEMON_STORE_AUDIT_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_AUDIT_REPOSITORY_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

struct AuditRecord {
  int64_t id = 0;
  int64_t time_ms = 0;
  std::string principal;
  std::string role;
  std::string auth_method;
  // How the call came: "grpc" (a network port), "http" (the HTTP edge,
  // through the daemon's in-process channel), "in-process" (an in-process
  // call without the edge's stamp); "" for the audit log's own notes.
  std::string transport;
  std::string peer;  // for "http", the HTTP client's address
  std::string method;
  std::string subject;
  int status_code = 0;  // gRPC / absl canonical code
  std::string message;
};

struct AuditFilter {
  std::string principal;  // empty = all
  std::string method;     // substring; empty = all
  int64_t start_ms = 0;   // 0 = no lower bound (inclusive)
  int64_t end_ms = 0;     // 0 = no upper bound (exclusive)
  int64_t before_id = 0;  // pagination: ids below this; 0 = from the newest
  int limit = 100;
};

class AuditRepository {
 public:
  explicit AuditRepository(Store& store) : store_(store) {}

  // Appends the rows in one transaction.
  absl::Status Append(const std::vector<AuditRecord>& records);
  // Newest first.
  absl::StatusOr<std::vector<AuditRecord>> List(const AuditFilter& filter);

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_AUDIT_REPOSITORY_H_
