// SPDX-License-Identifier: GPL-3.0-or-later
//
// The guard every call runs, on every path: a gRPC server interceptor, which
// gRPC runs for calls on the network ports and for in-process calls alike
// (the HTTP edge forwards its requests through the server's in-process
// channel, which no AuthMetadataProcessor sees). When a call's metadata
// arrives it decides:
//  - the caller: on a network port from the connection's TLS or local auth
//    context and the call's authorization metadata, as CallGuard does (and a
//    call carrying the HTTP edge's stamp is refused); for an in-process call
//    (its auth context has no transport_security_type) only from a valid
//    EdgeStamp, never from anything else the call carries;
//  - then the one role table and the rig lock (CallGuard::Authorize).
// An interceptor cannot refuse a call, so it records the decision in
// CallDecisions, keyed by the call's ServerContext, and every handler of
// every hdrstereo.v1 service starts with the prologue CallDecisions::Admit,
// which returns the refusal (or, if no decision was recorded, INTERNAL: fail
// closed). The decision is removed when the call ends.
//
// It also audits: every refusal it makes (once; calls CallGuard refused on a
// network port never get here, and were audited there), and every admitted
// call the role table marks as changing something, whatever its outcome,
// with the caller it decided, the transport ("grpc", "http"), the peer (for
// HTTP, the client's address from the stamp), the method, the subject (from
// the request: session, job, schedule, key; and the job a submission
// created) and the status.
//
// gRPC's health and reflection services have no prologue: an in-process
// call to them is not refused (the HTTP edge forwards hdrstereo.v1 methods
// only); on the network ports CallGuard guards them.
#ifndef HDRSTEREO_DAEMON_RPC_CALL_GUARD_INTERCEPTOR_H_
#define HDRSTEREO_DAEMON_RPC_CALL_GUARD_INTERCEPTOR_H_

#include <google/protobuf/message.h>
#include <grpcpp/server_context.h>
#include <grpcpp/support/server_interceptor.h>
#include <grpcpp/support/status.h>

#include <memory>
#include <string>
#include <unordered_map>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "daemon/rpc/audit_log.h"
#include "daemon/rpc/authenticator.h"
#include "daemon/rpc/call_guard.h"
#include "daemon/rpc/edge_stamp.h"

namespace hdrstereo::rpc {

// What a request is about, for people: "session lab-1", "job 12",
// "schedule nightly", "key 0a1b2c3d4e5f", "user bob", joined by ", ".
std::string AuditSubject(const google::protobuf::Message& request);

// Who made an admitted call, and how.
struct Caller {
  Principal principal;
  std::string transport;  // kGrpcTransport or kHttpTransport
  std::string peer;       // the caller's address (HTTP: the HTTP client's)
};

// The guard's decision on each call in flight, by its ServerContext: the
// caller, or the refusal. Thread-safe.
class CallDecisions {
 public:
  // Records the decision `owner` (the call's interceptor) took for the call
  // of `context`; Forget removes it, unless another owner has recorded one
  // for a later call with the same context address since.
  void Record(const grpc::ServerContextBase* context, const void* owner,
              absl::StatusOr<Caller> decision) ABSL_LOCKS_EXCLUDED(mutex_);
  void Forget(const grpc::ServerContextBase* context, const void* owner)
      ABSL_LOCKS_EXCLUDED(mutex_);

  // The prologue every handler of every hdrstereo.v1 service starts with:
  //   if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  // (or Admit(*context, &caller) for a handler that needs the caller). OK
  // when the guard admitted the call, filling `caller` when given; else the
  // guard's refusal, or INTERNAL when it recorded no decision for the call.
  grpc::Status Admit(const grpc::ServerContextBase& context,
                     Caller* caller = nullptr) const
      ABSL_LOCKS_EXCLUDED(mutex_);

 private:
  struct Decision {
    const void* owner;
    absl::StatusOr<Caller> caller;
  };
  mutable absl::Mutex mutex_;
  std::unordered_map<const grpc::ServerContextBase*, Decision> decisions_
      ABSL_GUARDED_BY(mutex_);
};

class CallGuardInterceptorFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  // `guard` is shared with the ports' credentials; the others outlive the
  // server the factory is installed on.
  CallGuardInterceptorFactory(std::shared_ptr<CallGuard> guard,
                              const EdgeStamp& stamp, AuditLog& audit,
                              CallDecisions& decisions)
      : guard_(std::move(guard)),
        stamp_(stamp),
        audit_(audit),
        decisions_(decisions) {}

  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override;

 private:
  std::shared_ptr<CallGuard> guard_;
  const EdgeStamp& stamp_;
  AuditLog& audit_;
  CallDecisions& decisions_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_CALL_GUARD_INTERCEPTOR_H_
