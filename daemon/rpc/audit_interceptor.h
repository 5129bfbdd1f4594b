// SPDX-License-Identifier: GPL-3.0-or-later
//
// Audits every call the role table marks as changing something, whatever
// its outcome: a gRPC server interceptor, so no handler has to remember
// it. It records the caller (resolved again from the call), its address,
// the method, the subject (from the request: session, job, schedule, key;
// and the job a submission created) and the status. Refused calls are
// audited by CallGuard before they get here.
#ifndef HDRSTEREO_DAEMON_RPC_AUDIT_INTERCEPTOR_H_
#define HDRSTEREO_DAEMON_RPC_AUDIT_INTERCEPTOR_H_

#include <google/protobuf/message.h>
#include <grpcpp/support/server_interceptor.h>

#include <string>

#include "daemon/rpc/audit_log.h"
#include "daemon/rpc/authenticator.h"

namespace hdrstereo::rpc {

// What a request is about, for people: "session lab-1", "job 12",
// "schedule nightly", "key 0a1b2c3d4e5f", "user bob", joined by ", ".
std::string AuditSubject(const google::protobuf::Message& request);

class AuditInterceptorFactory final
    : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  AuditInterceptorFactory(Authenticator& authenticator, AuditLog& audit)
      : authenticator_(authenticator), audit_(audit) {}

  grpc::experimental::Interceptor* CreateServerInterceptor(
      grpc::experimental::ServerRpcInfo* info) override;

 private:
  Authenticator& authenticator_;
  AuditLog& audit_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_AUDIT_INTERCEPTOR_H_
