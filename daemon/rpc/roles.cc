// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/roles.h"

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"

namespace hdrstereo::rpc {

const char* RoleName(Role role) {
  switch (role) {
    case Role::kNone:
      return "none";
    case Role::kViewer:
      return "viewer";
    case Role::kOperator:
      return "operator";
    case Role::kAdmin:
      return "admin";
  }
  return "none";
}

absl::StatusOr<Role> ParseRole(absl::string_view name) {
  for (Role role :
       {Role::kNone, Role::kViewer, Role::kOperator, Role::kAdmin}) {
    if (name == RoleName(role)) return role;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      QuoteInput(name), " is not a role: use viewer, operator or admin"));
}

absl::Status ValidatePrincipalName(absl::string_view name,
                                   absl::string_view what) {
  if (name.empty() || name.size() > 64) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, ": a user name has 1 to 64 characters, not ", name.size()));
  }
  for (char c : name) {
    if (!absl::ascii_isalnum(c) && c != '.' && c != '_' && c != '@' &&
        c != '-') {
      return absl::InvalidArgumentError(
          absl::StrCat(what, ": user name ", QuoteInput(name), " contains '",
                       absl::CHexEscape(absl::string_view(&c, 1)),
                       "'; use letters, digits, '.', '_', '@' and '-'"));
    }
  }
  return absl::OkStatus();
}

}  // namespace hdrstereo::rpc
