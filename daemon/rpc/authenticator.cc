// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/authenticator.h"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::rpc {
namespace {

constexpr absl::string_view kBearer = "Bearer ";
constexpr absl::string_view kUserUri = "hdrstereo://user/";

std::string FirstProperty(const grpc::AuthContext& context,
                          const std::string& name) {
  std::vector<grpc::string_ref> values = context.FindPropertyValues(name);
  if (values.empty()) return "";
  return std::string(values[0].data(), values[0].size());
}

std::string PrincipalOfConnection(const grpc::AuthContext& context) {
  std::vector<std::string> names;
  for (const grpc::string_ref& san :
       context.FindPropertyValues("x509_subject_alternative_name")) {
    names.emplace_back(san.data(), san.size());
  }
  return CertificatePrincipal(names,
                              FirstProperty(context, "x509_common_name"));
}

}  // namespace

std::string CertificatePrincipal(
    const std::vector<std::string>& subject_alternative_names,
    absl::string_view common_name) {
  for (absl::string_view name : subject_alternative_names) {
    if (absl::StartsWith(name, kUserUri)) {
      return std::string(name.substr(kUserUri.size()));
    }
  }
  return std::string(common_name);
}

Role Authenticator::RoleOf(absl::string_view user) const {
  auto it = users_.find(user);
  return it == users_.end() ? Role::kNone : it->second;
}

absl::Status Authenticator::Authenticate(
    const grpc::AuthContext& connection,
    std::optional<absl::string_view> authorization, Principal* principal) {
  *principal = Principal();
  // gRPC's SSL credentials say "ssl", its TLS credentials "tls", its local
  // credentials "local"; anything else is not a transport the daemon set up.
  const std::string transport =
      FirstProperty(connection, "transport_security_type");
  const bool tls = transport == "ssl" || transport == "tls";
  if (!tls && transport != "local") {
    return absl::UnauthenticatedError(
        absl::StrCat("the connection's transport \"", transport,
                     "\" is not one hdrstereod serves"));
  }
  if (authorization.has_value()) {
    absl::string_view token = *authorization;
    const bool bearer = absl::StartsWith(token, kBearer);
    if (bearer) token.remove_prefix(kBearer.size());
    const std::string id = ApiKeyIdOf(token);
    principal->auth_method = id.empty() ? "key" : absl::StrCat("key:", id);
    if (!tls) {
      // The key crossed the wire in the clear: say so where the admin
      // looks, without the key.
      spdlog::warn(
          "refused an API key{} sent without TLS; whoever could see that "
          "traffic may have it: revoke it (hdrstereo admin key revoke ID)",
          id.empty() ? "" : absl::StrCat(" (id ", id, ")"));
      return absl::UnauthenticatedError(
          "API keys are accepted over TLS only; connect with --tls-ca (the "
          "key was sent in the clear: have it revoked)");
    }
    if (!bearer) {
      return absl::UnauthenticatedError(
          "the authorization header must be \"Bearer hs_<id>_<secret>\"");
    }
    ASSIGN_OR_RETURN(VerifiedApiKey key, keys_.Verify(token));
    principal->name = key.user;
    principal->role = std::min(key.role, RoleOf(key.user));
    principal->key_expire_time = key.expire_time;
    return absl::OkStatus();
  }
  if (tls) {
    if (!connection.IsPeerAuthenticated()) {
      return absl::UnauthenticatedError(
          "no client certificate and no API key: connect with --tls-cert "
          "and --tls-key signed by the lab CA, or --api-key-file");
    }
    principal->auth_method = "cert";
    principal->name = PrincipalOfConnection(connection);
    if (absl::Status s =
            ValidatePrincipalName(principal->name, "the client certificate");
        !s.ok()) {
      return absl::UnauthenticatedError(
          absl::StrCat(s.message(),
                       "; its SAN URI hdrstereo://user/NAME or CN must name "
                       "the user"));
    }
    principal->role = RoleOf(principal->name);
    return absl::OkStatus();
  }
  principal->name = kLocalPrincipal;
  principal->auth_method = "local";
  principal->role = local_role_;
  return absl::OkStatus();
}

}  // namespace hdrstereo::rpc
