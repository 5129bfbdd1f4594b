// SPDX-License-Identifier: GPL-3.0-or-later
//
// From an HTTP route to the gRPC method it names, and bodies to messages:
// the edge serves exactly the methods of the hdrstereo.v1 services in the
// generated descriptor pool (no list of its own, so a new RPC is on HTTP
// the day it is on gRPC) and converts bodies with protobuf's JSON mapping.
#ifndef HDRSTEREO_DAEMON_HTTP_RPC_ROUTES_H_
#define HDRSTEREO_DAEMON_HTTP_RPC_ROUTES_H_

#include <google/protobuf/descriptor.h>

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/http/connect_protocol.h"

namespace hdrstereo::http {

// The package whose services the edge serves.
inline constexpr char kServedPackage[] = "hdrstereo.v1";

struct RpcMethod {
  const google::protobuf::MethodDescriptor* descriptor = nullptr;
  std::string grpc_path;  // "/hdrstereo.v1.Jobs/Get"
};

// The method of a route "/hdrstereo.v1.<Service>/<Method>". NOT_FOUND when
// the path is no such route at all (another prefix, more segments);
// UNIMPLEMENTED for a route into the package that names no method, or a
// client-streaming one (the edge serves unary and server-streaming calls).
absl::StatusOr<RpcMethod> FindRpcMethod(absl::string_view path);

// A request body in `codec` as the request message's bytes: JSON through
// protobuf's JSON mapping (unknown fields refused; an empty body is the
// empty message), binary checked by parsing. INVALID_ARGUMENT naming the
// message type and what protobuf found wrong (quoted, bounded).
absl::StatusOr<std::string> RequestBytes(const RpcMethod& method, Codec codec,
                                         absl::string_view body);
// A response message's bytes in `codec` (JSON: proto3's JSON mapping,
// lowerCamelCase names, int64 as strings).
absl::StatusOr<std::string> ResponseBody(const RpcMethod& method, Codec codec,
                                         absl::string_view bytes);

}  // namespace hdrstereo::http

#endif  // HDRSTEREO_DAEMON_HTTP_RPC_ROUTES_H_
