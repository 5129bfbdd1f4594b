// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/server_service.h"

#include <grpcpp/grpcpp.h>
#include <sqlite3.h>

#include <opencv2/core/utility.hpp>

#include "absl/time/clock.h"
#include "hdrstereo_version.h"

namespace hdrstereo::rpc {

grpc::Status ServerService::GetInfo(grpc::ServerContext*,
                                    const v1::GetServerInfoRequest*,
                                    v1::ServerInfo* response) {
  response->set_version(HDRSTEREO_VERSION);
  response->set_schema_version(store_.schema_version());
  response->set_data_root(store_.files().root().string());
  response->set_hardware_mode(hardware_mode_);
  response->set_uptime_s(absl::ToInt64Seconds(absl::Now() - start_time_));
  response->set_grpc_version(grpc::Version());
  response->set_opencv_version(cv::getVersionString());
  response->set_sqlite_version(sqlite3_libversion());
  return grpc::Status::OK;
}

}  // namespace hdrstereo::rpc
