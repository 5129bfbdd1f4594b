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

// absl and gRPC share the canonical code numbering; ToGrpcStatus casts one
// to the other, so the build proves it for every code.
#define HDRSTEREO_SAME_CODE(absl_name, grpc_name)                  \
  static_assert(static_cast<int>(absl::StatusCode::absl_name) ==   \
                    static_cast<int>(grpc::StatusCode::grpc_name), \
                #absl_name " and " #grpc_name " differ")
HDRSTEREO_SAME_CODE(kOk, OK);
HDRSTEREO_SAME_CODE(kCancelled, CANCELLED);
HDRSTEREO_SAME_CODE(kUnknown, UNKNOWN);
HDRSTEREO_SAME_CODE(kInvalidArgument, INVALID_ARGUMENT);
HDRSTEREO_SAME_CODE(kDeadlineExceeded, DEADLINE_EXCEEDED);
HDRSTEREO_SAME_CODE(kNotFound, NOT_FOUND);
HDRSTEREO_SAME_CODE(kAlreadyExists, ALREADY_EXISTS);
HDRSTEREO_SAME_CODE(kPermissionDenied, PERMISSION_DENIED);
HDRSTEREO_SAME_CODE(kResourceExhausted, RESOURCE_EXHAUSTED);
HDRSTEREO_SAME_CODE(kFailedPrecondition, FAILED_PRECONDITION);
HDRSTEREO_SAME_CODE(kAborted, ABORTED);
HDRSTEREO_SAME_CODE(kOutOfRange, OUT_OF_RANGE);
HDRSTEREO_SAME_CODE(kUnimplemented, UNIMPLEMENTED);
HDRSTEREO_SAME_CODE(kInternal, INTERNAL);
HDRSTEREO_SAME_CODE(kUnavailable, UNAVAILABLE);
HDRSTEREO_SAME_CODE(kDataLoss, DATA_LOSS);
HDRSTEREO_SAME_CODE(kUnauthenticated, UNAUTHENTICATED);
#undef HDRSTEREO_SAME_CODE

inline grpc::Status ToGrpcStatus(const absl::Status& status) {
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()),
                      std::string(status.message()));
}

inline grpc::Status InvalidArgument(const std::string& message) {
  return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, message);
}

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_STATUS_H_
