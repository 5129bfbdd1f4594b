// SPDX-License-Identifier: GPL-3.0-or-later
//
// absl::Status -> grpc::Status at the RPC edge (the only place gRPC types
// meet the rest of the daemon).
#ifndef HDRSTEREO_DAEMON_RPC_STATUS_H_
#define HDRSTEREO_DAEMON_RPC_STATUS_H_

#include <grpcpp/support/status.h>

#include <string>

#include "absl/status/status.h"

namespace hdrstereo::rpc {

inline grpc::Status ToGrpcStatus(const absl::Status& status) {
  // absl and gRPC share the canonical code numbering.
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()),
                      std::string(status.message()));
}

inline grpc::Status InvalidArgument(const std::string& message) {
  return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, message);
}

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_STATUS_H_
