// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/call_guard.h"

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
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

// A method name as a caller sent it, fit for a message and the log.
std::string Shown(absl::string_view method) {
  return absl::CHexEscape(method.substr(0, 200));
}

}  // namespace

absl::Status CallGuard::Check(absl::string_view method,
                              const grpc::AuthContext& connection,
                              std::optional<absl::string_view> authorization,
                              Principal* principal) {
  RETURN_IF_ERROR(
      authenticator_.Authenticate(connection, authorization, principal));
  const MethodRule* rule = FindMethodRule(method);
  if (rule == nullptr) {
    return absl::UnimplementedError(
        absl::StrCat("hdrstereod serves no method ", Shown(method)));
  }
  if (principal->role < rule->min_role) {
    return absl::PermissionDeniedError(absl::StrCat(
        method, " needs role ", RoleName(rule->min_role), "; ", principal->name,
        " has ",
        principal->role == Role::kNone ? "no role" : RoleName(principal->role),
        principal->role == Role::kNone
            ? " (an admin gives one in [auth.users] of hdrstereod's config)"
            : ""));
  }
  if (rule->uses_rig) return rig_lock_.CheckFor(principal->name);
  return absl::OkStatus();
}

grpc::Status CallGuard::Process(const InputMetadata& metadata,
                                grpc::AuthContext* connection, OutputMetadata*,
                                OutputMetadata*) {
  const absl::string_view method = Find(metadata, ":path").value_or("");
  Principal principal;
  absl::Status status =
      Check(method, *connection, Find(metadata, "authorization"), &principal);
  if (status.ok()) return grpc::Status::OK;
  // The caller's address is not known here: gRPC authenticates before the
  // call reaches the server.
  store::AuditRecord row;
  row.principal = principal.name;
  row.role = RoleName(principal.role);
  row.auth_method = principal.auth_method;
  row.method = Shown(method);
  row.status_code = static_cast<int>(status.code());
  row.message = std::string(status.message());
  audit_.Record(std::move(row));
  return ToGrpcStatus(status);
}

}  // namespace hdrstereo::rpc
