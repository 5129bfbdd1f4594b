// SPDX-License-Identifier: GPL-3.0-or-later
//
// The gate every call on a network port passes before any handler runs:
// gRPC's AuthMetadataProcessor, installed on the credentials of every port
// the daemon listens on (TLS and local alike). For each call it
// authenticates the caller (Authenticator), refuses the HTTP edge's stamp
// (only in-process calls may carry it), looks the method up in the role
// table (deny by default), checks the caller's role, and for methods that
// use the rig checks the rig lock. Every refusal is audited. It runs on
// gRPC's transport threads and so never blocks: keys, roles and the lock are
// in memory, audit rows are queued.
//
// In-process calls (the HTTP edge's) never reach a metadata processor: the
// same decisions are taken again, for every call on every path, by
// CallGuardInterceptor (call_guard_interceptor.h), through Check and
// Authorize below; it also guards gRPC's health and reflection services,
// which have no handler prologue.
#ifndef HDRSTEREO_DAEMON_RPC_CALL_GUARD_H_
#define HDRSTEREO_DAEMON_RPC_CALL_GUARD_H_

#include <grpcpp/security/auth_metadata_processor.h>

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "daemon/jobs/rig_lock.h"
#include "daemon/rpc/audit_log.h"
#include "daemon/rpc/authenticator.h"

namespace hdrstereo::rpc {

// The transport an audit row names: a network port, the HTTP edge (an
// in-process call with a valid stamp), or an in-process call without one.
inline constexpr char kGrpcTransport[] = "grpc";
inline constexpr char kHttpTransport[] = "http";
inline constexpr char kInProcessTransport[] = "in-process";

// A method name as a caller sent it, fit for a message and the log: C-escaped,
// at most 200 bytes of it.
std::string ShownMethod(absl::string_view method);

class CallGuard final : public grpc::AuthMetadataProcessor {
 public:
  CallGuard(Authenticator& authenticator, jobs::RigLock& rig_lock,
            AuditLog& audit)
      : authenticator_(authenticator), rig_lock_(rig_lock), audit_(audit) {}

  bool IsBlocking() const override { return false; }
  grpc::Status Process(const InputMetadata& metadata,
                       grpc::AuthContext* connection, OutputMetadata* consumed,
                       OutputMetadata* response) override;

  // The decision for a call of `method` (full name) on a network port,
  // without auditing: UNAUTHENTICATED (also when `metadata` carries the HTTP
  // edge's stamp: HasEdgeStamp), UNIMPLEMENTED (no such method),
  // PERMISSION_DENIED naming the role needed, or FAILED_PRECONDITION (rig
  // lock). Fills `principal` with what is known of the caller.
  absl::Status CheckNetworkCall(absl::string_view method,
                                const grpc::AuthContext& connection,
                                const InputMetadata& metadata,
                                Principal* principal);
  // The same without the stamp check, `authorization` being the call's
  // authorization metadata.
  absl::Status Check(absl::string_view method,
                     const grpc::AuthContext& connection,
                     std::optional<absl::string_view> authorization,
                     Principal* principal);
  // The role table and the rig lock for a caller already authenticated:
  // UNIMPLEMENTED, PERMISSION_DENIED or FAILED_PRECONDITION as above.
  absl::Status Authorize(absl::string_view method, const Principal& principal);

 private:
  Authenticator& authenticator_;
  jobs::RigLock& rig_lock_;
  AuditLog& audit_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_CALL_GUARD_H_
