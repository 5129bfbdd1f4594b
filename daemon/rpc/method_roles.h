// SPDX-License-Identifier: GPL-3.0-or-later
//
// The one table of who may call what: every method the daemon serves, by
// full gRPC name ("/hdrstereo.v1.Jobs/Cancel"), with its minimum role,
// whether a successful call changes something (then it is audited), and
// whether it uses the rig (then the rig lock applies). A method that is not
// in the table is refused (deny by default); a unit test walks every method
// of every hdrstereo.v1 service so that none ships without an entry.
#ifndef HDRSTEREO_DAEMON_RPC_METHOD_ROLES_H_
#define HDRSTEREO_DAEMON_RPC_METHOD_ROLES_H_

#include <map>
#include <string>
#include <vector>

#include "absl/strings/string_view.h"
#include "daemon/rpc/roles.h"

namespace hdrstereo::rpc {

struct MethodRule {
  Role min_role = Role::kAdmin;
  bool mutating = false;  // audited also when it succeeds
  bool uses_rig = false;  // refused while another principal holds the lock
};

// Every served method, keyed by full name.
const std::map<std::string, MethodRule, std::less<>>& MethodRules();

// The rule for `full_method`, or nullptr when the daemon serves no such
// method.
const MethodRule* FindMethodRule(absl::string_view full_method);

// The full names of the methods of the services named (e.g.
// "hdrstereo.v1.Jobs", as in the generated descriptor pool) that have no
// rule; a service the pool does not know is reported by its name.
std::vector<std::string> MethodsWithoutRule(
    const std::vector<std::string>& services);

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_METHOD_ROLES_H_
