// SPDX-License-Identifier: GPL-3.0-or-later
#ifndef HDRSTEREO_DAEMON_RPC_SERVER_SERVICE_H_
#define HDRSTEREO_DAEMON_RPC_SERVER_SERVICE_H_

#include <string>

#include "absl/time/time.h"
#include "daemon/jobs/disk_guard.h"
#include "daemon/rpc/call_guard_interceptor.h"
#include "daemon/store/store.h"
#include "hdrstereo/v1/server.grpc.pb.h"

namespace hdrstereo::rpc {

// Server.GetInfo: versions, data root and its free space, hardware mode,
// uptime; WhoAmI: the caller as the daemon's guard decided it (for a call
// through the HTTP edge, the peer is the HTTP client's address).
class ServerService final : public v1::Server::Service {
 public:
  ServerService(store::Store& store, const jobs::DiskGuard& disk,
                const CallDecisions& calls, std::string hardware_mode,
                absl::Time start_time)
      : store_(store),
        disk_(disk),
        calls_(calls),
        hardware_mode_(std::move(hardware_mode)),
        start_time_(start_time) {}

  grpc::Status GetInfo(grpc::ServerContext* context,
                       const v1::GetServerInfoRequest* request,
                       v1::ServerInfo* response) override;
  grpc::Status WhoAmI(grpc::ServerContext* context,
                      const v1::WhoAmIRequest* request,
                      v1::Identity* response) override;

 private:
  store::Store& store_;
  const jobs::DiskGuard& disk_;
  const CallDecisions& calls_;
  std::string hardware_mode_;
  absl::Time start_time_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_SERVER_SERVICE_H_
