// SPDX-License-Identifier: GPL-3.0-or-later
//
// Who is calling: resolved for each call from the connection's
// grpc::AuthContext (TLS client certificate, or the local transport) and the
// call's own `authorization` metadata (an API key). Keys travel per call
// and the AuthContext is per connection, so nothing a call presents is ever
// stored in the AuthContext.
//
//  - An API key ("authorization: Bearer hs_<id>_<secret>") is accepted over
//    TLS only and names its user; its role is the key's, capped at the
//    user's role in [auth.users].
//  - Else a verified client certificate names the principal: its SAN URI
//    hdrstereo://user/NAME, else its CN; the role comes from [auth.users]
//    (none if the name is not there).
//  - Else a caller on a loopback address or unix socket is "local" with
//    --local-role.
#ifndef HDRSTEREO_DAEMON_RPC_AUTHENTICATOR_H_
#define HDRSTEREO_DAEMON_RPC_AUTHENTICATOR_H_

#include <grpcpp/security/auth_context.h>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "daemon/rpc/api_keys.h"
#include "daemon/rpc/roles.h"

namespace hdrstereo::rpc {

inline constexpr char kLocalPrincipal[] = "local";

// Roles by principal name, as [auth.users] gives them.
using RoleMap = std::map<std::string, Role, std::less<>>;

struct Principal {
  std::string name;  // "" when the caller could not be identified
  Role role = Role::kNone;
  std::string auth_method;  // "cert", "key:<id>", "local"; "" for none
  std::optional<absl::Time> key_expire_time;
};

// The principal a verified client certificate names, the one rule for
// gRPC and HTTP: its SAN URI hdrstereo://user/NAME, else its CN.
std::string CertificatePrincipal(
    const std::vector<std::string>& subject_alternative_names,
    absl::string_view common_name);

class Authenticator {
 public:
  Authenticator(RoleMap users, Role local_role, ApiKeyStore& keys)
      : users_(std::move(users)), local_role_(local_role), keys_(keys) {}

  // Fills `principal` with what the call shows of its caller (also when it
  // fails, for the audit log) and returns UNAUTHENTICATED, with a message a
  // person can act on, when the call carries no usable credentials.
  // `authorization` is the call's authorization metadata, if any.
  absl::Status Authenticate(const grpc::AuthContext& connection,
                            std::optional<absl::string_view> authorization,
                            Principal* principal);

  // The role [auth.users] gives `user` (kNone when it names no such user).
  Role RoleOf(absl::string_view user) const;

 private:
  const RoleMap users_;
  const Role local_role_;
  ApiKeyStore& keys_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_AUTHENTICATOR_H_
