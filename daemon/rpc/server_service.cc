// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/server_service.h"

#include <google/protobuf/util/time_util.h>
#include <grpcpp/grpcpp.h>
#include <sqlite3.h>

#include <opencv2/core/utility.hpp>

#include "absl/time/clock.h"
#include "daemon/rpc/role_proto.h"
#include "daemon/rpc/status.h"
#include "hdrstereo_version.h"

namespace hdrstereo::rpc {

grpc::Status ServerService::GetInfo(grpc::ServerContext* context,
                                    const v1::GetServerInfoRequest*,
                                    v1::ServerInfo* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  response->set_version(HDRSTEREO_VERSION);
  response->set_schema_version(store_.schema_version());
  response->set_data_root(store_.files().root().string());
  response->set_hardware_mode(hardware_mode_);
  response->set_uptime_s(absl::ToInt64Seconds(absl::Now() - start_time_));
  response->set_grpc_version(grpc::Version());
  response->set_opencv_version(cv::getVersionString());
  response->set_sqlite_version(sqlite3_libversion());
  absl::StatusOr<int64_t> free = disk_.FreeBytes();
  if (!free.ok()) return ToGrpcStatus(free.status());
  response->set_data_root_free_bytes(*free);
  absl::StatusOr<int64_t> pending = disk_.PendingCaptureBytes();
  if (!pending.ok()) return ToGrpcStatus(pending.status());
  response->set_pending_capture_bytes(*pending);
  return grpc::Status::OK;
}

grpc::Status ServerService::WhoAmI(grpc::ServerContext* context,
                                   const v1::WhoAmIRequest*,
                                   v1::Identity* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  response->set_principal(caller.principal.name);
  response->set_role(ToProto(caller.principal.role));
  response->set_auth_method(caller.principal.auth_method);
  if (caller.principal.key_expire_time.has_value()) {
    *response->mutable_key_expire_time() =
        google::protobuf::util::TimeUtil::MillisecondsToTimestamp(
            absl::ToUnixMillis(*caller.principal.key_expire_time));
  }
  response->set_peer(caller.peer);
  return grpc::Status::OK;
}

}  // namespace hdrstereo::rpc
