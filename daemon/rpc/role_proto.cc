// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/role_proto.h"

namespace hdrstereo::rpc {

v1::Role ToProto(Role role) {
  switch (role) {
    case Role::kViewer:
      return v1::ROLE_VIEWER;
    case Role::kOperator:
      return v1::ROLE_OPERATOR;
    case Role::kAdmin:
      return v1::ROLE_ADMIN;
    case Role::kNone:
      break;
  }
  return v1::ROLE_UNSPECIFIED;
}

Role FromProto(v1::Role role) {
  switch (role) {
    case v1::ROLE_VIEWER:
      return Role::kViewer;
    case v1::ROLE_OPERATOR:
      return Role::kOperator;
    case v1::ROLE_ADMIN:
      return Role::kAdmin;
    default:
      return Role::kNone;
  }
}

}  // namespace hdrstereo::rpc
