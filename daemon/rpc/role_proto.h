// SPDX-License-Identifier: GPL-3.0-or-later
//
// Roles on the wire: rpc::Role and v1::Role.
#ifndef HDRSTEREO_DAEMON_RPC_ROLE_PROTO_H_
#define HDRSTEREO_DAEMON_RPC_ROLE_PROTO_H_

#include "daemon/rpc/roles.h"
#include "hdrstereo/v1/common.pb.h"

namespace hdrstereo::rpc {

v1::Role ToProto(Role role);
Role FromProto(v1::Role role);

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_ROLE_PROTO_H_
