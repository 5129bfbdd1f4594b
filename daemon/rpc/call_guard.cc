// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/call_guard.h"

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "daemon/rpc/edge_stamp.h"
#include "daemon/rpc/method_roles.h"
#include "daemon/rpc/status.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::rpc {
namespace {

std::optional<absl::string_view> Find(
    const grpc::AuthMetadataProcessor::InputMetadata& metadata,
    const char* key) {
  auto it = metadata.find(key);
  if (it == metadata.end()) return std::nullopt;
  return absl::string_view(it->second.data(), it->second.size());
}

}  // namespace

std::string ShownMethod(absl::string_view method) {
  return absl::CHexEscape(method.substr(0, 200));
}

absl::Status CallGuard::Check(absl::string_view method,
                              const grpc::AuthContext& connection,
                              std::optional<absl::string_view> authorization,
                              Principal* principal) {
  RETURN_IF_ERROR(
      authenticator_.Authenticate(connection, authorization, principal));
  return Authorize(method, *principal);
}

absl::Status CallGuard::Authorize(absl::string_view method,
                                  const Principal& principal) {
  const MethodRule* rule = FindMethodRule(method);
  if (rule == nullptr) {
    return absl::UnimplementedError(
        absl::StrCat("hdrstereod serves no method ", ShownMethod(method)));
  }
  if (principal.role < rule->min_role) {
    return absl::PermissionDeniedError(absl::StrCat(
        method, " needs role ", RoleName(rule->min_role), "; ", principal.name,
        " has ",
        principal.role == Role::kNone ? "no role" : RoleName(principal.role),
        principal.role == Role::kNone
            ? " (an admin gives one in [auth.users] of hdrstereod's config)"
            : ""));
  }
  if (rule->uses_rig) return rig_lock_.CheckFor(principal.name);
  return absl::OkStatus();
}

absl::Status CallGuard::CheckNetworkCall(absl::string_view method,
                                         const grpc::AuthContext& connection,
                                         const InputMetadata& metadata,
                                         Principal* principal) {
  const std::optional<absl::string_view> authorization =
      Find(metadata, "authorization");
  if (HasEdgeStamp(metadata)) {
    // Who sent it, for the audit row; the call is refused whoever it is.
    authenticator_.Authenticate(connection, authorization, principal)
        .IgnoreError();
    return absl::UnauthenticatedError(absl::StrCat(
        kEdgeStampKey, " and ", kEdgeCallerKey,
        " are set only by hdrstereod's own HTTP edge on the calls it makes "
        "inside the daemon; a call over the network may not carry them"));
  }
  return Check(method, connection, authorization, principal);
}

grpc::Status CallGuard::Process(const InputMetadata& metadata,
                                grpc::AuthContext* connection, OutputMetadata*,
                                OutputMetadata*) {
  const absl::string_view method = Find(metadata, ":path").value_or("");
  Principal principal;
  absl::Status status =
      CheckNetworkCall(method, *connection, metadata, &principal);
  if (status.ok()) return grpc::Status::OK;
  // The caller's address is not known here: gRPC authenticates before the
  // call reaches the server.
  store::AuditRecord row;
  row.principal = principal.name;
  row.role = RoleName(principal.role);
  row.auth_method = principal.auth_method;
  row.transport = kGrpcTransport;
  row.method = ShownMethod(method);
  row.status_code = static_cast<int>(status.code());
  row.message = std::string(status.message());
  audit_.Record(std::move(row));
  return ToGrpcStatus(status);
}

}  // namespace hdrstereo::rpc
