// SPDX-License-Identifier: GPL-3.0-or-later
//
// Wires the store and the gRPC services into one serving daemon.
#ifndef HDRSTEREO_DAEMON_SERVER_H_
#define HDRSTEREO_DAEMON_SERVER_H_

#include <grpcpp/server.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "daemon/config.h"
#include "daemon/hardware_setup.h"
#include "daemon/http/http_edge.h"
#include "daemon/jobs/disk_guard.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/jobs/processing_job.h"
#include "daemon/jobs/rig_lock.h"
#include "daemon/jobs/scheduler.h"
#include "daemon/metrics/metrics_exporter.h"
#include "daemon/notify/webhook_dispatcher.h"
#include "daemon/notify/webhook_signing.h"
#include "daemon/rpc/admin_service.h"
#include "daemon/rpc/api_keys.h"
#include "daemon/rpc/audit_log.h"
#include "daemon/rpc/authenticator.h"
#include "daemon/rpc/call_guard_interceptor.h"
#include "daemon/rpc/edge_stamp.h"
#include "daemon/rpc/hardware_service.h"
#include "daemon/rpc/jobs_service.h"
#include "daemon/rpc/schedules_service.h"
#include "daemon/rpc/server_service.h"
#include "daemon/rpc/sessions_service.h"
#include "daemon/store/store.h"

namespace hdrstereo::daemon {

class Server {
 public:
  // Opens the store and starts serving; fails (and serves nothing) when the
  // data root, database, TLS files or a listen address is unusable.
  static absl::StatusOr<std::unique_ptr<Server>> Start(const Config& config);
  ~Server();

  // The addresses actually bound, in --listen order (ports resolved when 0
  // was asked for).
  const std::vector<std::string>& addresses() const { return addresses_; }
  // The port metrics are served on; 0 when --metrics-listen is off.
  int metrics_port() const { return metrics_ ? metrics_->port() : 0; }
  // Stops the jobs at their next checkpoint (they resume at the next start),
  // stops accepting calls, lets in-flight calls finish (up to a deadline),
  // then releases the hardware and closes the database.
  void Shutdown();

  // For the HTTP edge. A channel to the services inside this process (one
  // per call of this function; null after Shutdown): its calls run no
  // AuthMetadataProcessor, so the guard admits them only with the stamp of
  // edge_stamp() (rpc/call_guard_interceptor.h).
  std::shared_ptr<grpc::Channel> InProcessChannel();
  // This boot's stamp.
  const rpc::EdgeStamp& edge_stamp() const { return edge_stamp_; }
  rpc::ApiKeyStore& api_keys() { return *api_keys_; }
  rpc::Authenticator& authenticator() { return authenticator_; }
  rpc::AuditLog& audit_log() { return audit_log_; }
  store::Store& store() { return *store_; }

 private:
  Server(std::unique_ptr<store::Store> store,
         std::unique_ptr<Hardware> hardware,
         std::unique_ptr<jobs::RigLock> rig_lock,
         std::unique_ptr<rpc::ApiKeyStore> api_keys,
         notify::WebhookSigner signer, rpc::EdgeStamp edge_stamp,
         const Config& config);

  // Declaration order is destruction order reversed: the services and the
  // engine go before the hardware and the store they use.
  std::unique_ptr<store::Store> store_;
  std::unique_ptr<Hardware> hardware_;
  std::unique_ptr<jobs::RigLock> rig_lock_;
  std::unique_ptr<rpc::ApiKeyStore> api_keys_;
  notify::WebhookSigner webhook_signer_;
  rpc::Authenticator authenticator_;
  rpc::AuditLog audit_log_;
  const rpc::EdgeStamp edge_stamp_;
  // Threads, memory budget and backend of processing jobs.
  const jobs::ProcessingEnvironment processing_;
  // The guard's decision on each call in flight, which every handler's
  // prologue reads.
  rpc::CallDecisions call_decisions_;
  jobs::JobEngine engine_;
  notify::WebhookDispatcher webhooks_;
  jobs::DiskGuard disk_guard_;
  std::unique_ptr<metrics::MetricsExporter> metrics_;  // null when off
  rpc::ServerService server_service_;
  rpc::SessionsService sessions_service_;
  rpc::HardwareService hardware_service_;
  rpc::JobsService jobs_service_;
  jobs::Scheduler scheduler_;
  rpc::SchedulesService schedules_service_;
  rpc::AdminService admin_service_;
  std::unique_ptr<grpc::Server> grpc_server_;
  std::unique_ptr<http::HttpEdge> http_;  // null when --http-listen is off
  std::vector<std::string> addresses_;
};

}  // namespace hdrstereo::daemon

#endif  // HDRSTEREO_DAEMON_SERVER_H_
