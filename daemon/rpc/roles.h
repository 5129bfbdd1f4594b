// SPDX-License-Identifier: GPL-3.0-or-later
//
// Roles (viewer < operator < admin) and principal names, as the RPC edge
// and the configuration spell them (on the wire: role_proto.h, apart, so
// that the configuration reads roles without the protocol).
#ifndef HDRSTEREO_DAEMON_RPC_ROLES_H_
#define HDRSTEREO_DAEMON_RPC_ROLES_H_

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::rpc {

// Ordered: a role includes every role below it. kNone is an authenticated
// principal that no configuration gives a role.
enum class Role { kNone = 0, kViewer = 1, kOperator = 2, kAdmin = 3 };

// "none", "viewer", "operator", "admin".
const char* RoleName(Role role);
// The inverse of RoleName; INVALID_ARGUMENT for anything else.
absl::StatusOr<Role> ParseRole(absl::string_view name);

// A principal (user) name: 1-64 of letters, digits, '.', '_', '@', '-'.
// INVALID_ARGUMENT naming `what` otherwise.
absl::Status ValidatePrincipalName(absl::string_view name,
                                   absl::string_view what);

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_ROLES_H_
