// SPDX-License-Identifier: GPL-3.0-or-later
//
// The gate every call passes before any handler runs: gRPC's
// AuthMetadataProcessor, installed on the credentials of every port the
// daemon listens on (TLS and local alike), so no method can be reached
// around it. For each call it authenticates the caller (Authenticator),
// looks the method up in the role table (deny by default), checks the
// caller's role, and for methods that use the rig checks the rig lock.
// Every refusal is audited. It runs on gRPC's transport threads and so
// never blocks: keys, roles and the lock are in memory, audit rows are
// queued.
#ifndef HDRSTEREO_DAEMON_RPC_CALL_GUARD_H_
#define HDRSTEREO_DAEMON_RPC_CALL_GUARD_H_

#include <grpcpp/security/auth_metadata_processor.h>

#include <optional>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "daemon/jobs/rig_lock.h"
#include "daemon/rpc/audit_log.h"
#include "daemon/rpc/authenticator.h"

namespace hdrstereo::rpc {

class CallGuard final : public grpc::AuthMetadataProcessor {
 public:
  CallGuard(Authenticator& authenticator, jobs::RigLock& rig_lock,
            AuditLog& audit)
      : authenticator_(authenticator), rig_lock_(rig_lock), audit_(audit) {}

  bool IsBlocking() const override { return false; }
  grpc::Status Process(const InputMetadata& metadata,
                       grpc::AuthContext* connection, OutputMetadata* consumed,
                       OutputMetadata* response) override;

  // The decision for a call of `method` (full name), without auditing:
  // UNAUTHENTICATED, UNIMPLEMENTED (no such method), PERMISSION_DENIED
  // naming the role needed, or FAILED_PRECONDITION (rig lock). Fills
  // `principal` with what is known of the caller.
  absl::Status Check(absl::string_view method,
                     const grpc::AuthContext& connection,
                     std::optional<absl::string_view> authorization,
                     Principal* principal);

 private:
  Authenticator& authenticator_;
  jobs::RigLock& rig_lock_;
  AuditLog& audit_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_CALL_GUARD_H_
