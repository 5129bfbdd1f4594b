// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/spdlog.h>

#include <chrono>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "daemon/jobs/capture_job.h"
#include "processing/io/atomic_file.h"

namespace hdrstereo::daemon {
namespace {

// The scheduler's clock runs `scheduler_clock_rate` times as fast as the
// wall clock from the daemon's start (1 = the wall clock; tests only).
jobs::SchedulerOptions SchedulerOptionsFor(const Config& config) {
  jobs::SchedulerOptions options;
  if (config.scheduler_clock_rate != 1.0) {
    const absl::Time start = absl::Now();
    const double rate = config.scheduler_clock_rate;
    options.clock = [start, rate] {
      return start + (absl::Now() - start) * rate;
    };
  }
  return options;
}

}  // namespace

Server::Server(std::unique_ptr<store::Store> store,
               std::unique_ptr<Hardware> hardware, const Config& config)
    : store_(std::move(store)),
      hardware_(std::move(hardware)),
      engine_(
          *store_,
          [rig = hardware_->rig.get()](jobs::JobContext& context) {
            return jobs::RunCaptureJob(*rig, context);
          },
          [](jobs::JobContext&) {
            return absl::UnimplementedError(
                "processing jobs are not implemented yet");
          },
          {.processing_threads = config.processing_threads,
           .resume_interrupted = config.resume_interrupted}),
      server_service_(*store_, config.hardware, absl::Now()),
      sessions_service_(*store_),
      hardware_service_(*hardware_->rig),
      jobs_service_(engine_, *hardware_->rig),
      scheduler_(
          *store_,
          [this](absl::string_view session,
                 const v1::CapturePlan& plan) -> absl::StatusOr<int64_t> {
            absl::StatusOr<store::JobRecord> job =
                jobs::SubmitCapture(engine_, *hardware_->rig, session, plan);
            if (!job.ok()) return job.status();
            return job->id;
          },
          SchedulerOptionsFor(config)),
      schedules_service_(scheduler_, *hardware_->rig) {}

absl::StatusOr<std::unique_ptr<Server>> Server::Start(const Config& config) {
  absl::StatusOr<std::unique_ptr<store::Store>> store =
      store::Store::Open(config.data_root);
  if (!store.ok()) return store.status();
  spdlog::info("data root {} (schema version {})",
               (*store)->files().root().string(), (*store)->schema_version());

  absl::StatusOr<std::unique_ptr<Hardware>> hardware = SetUpHardware(config);
  if (!hardware.ok()) return hardware.status();
  std::unique_ptr<Server> server(
      new Server(*std::move(store), *std::move(hardware), config));
  if (absl::Status s = server->engine_.Start(); !s.ok()) return s;
  if (absl::Status s = server->scheduler_.Start(); !s.ok()) return s;
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(config.listen, grpc::InsecureServerCredentials(),
                           &port);
  builder.RegisterService(&server->server_service_);
  builder.RegisterService(&server->sessions_service_);
  builder.RegisterService(&server->hardware_service_);
  builder.RegisterService(&server->jobs_service_);
  builder.RegisterService(&server->schedules_service_);
  server->grpc_server_ = builder.BuildAndStart();
  if (server->grpc_server_ == nullptr || port == 0) {
    return absl::UnavailableError(
        absl::StrCat("cannot listen on ", config.listen,
                     " (address in use, or not a local address?)"));
  }
  if (config.listen.starts_with("unix:")) {
    server->address_ = config.listen;
  } else {
    server->address_ = absl::StrCat(
        config.listen.substr(0, config.listen.rfind(':')), ":", port);
  }
  spdlog::info("serving gRPC on {}", server->address_);
  if (!config.ready_file.empty()) {
    if (absl::Status s =
            io::WriteFileAtomically(config.ready_file, server->address_ + "\n");
        !s.ok()) {
      server->Shutdown();
      return s;
    }
  }
  return server;
}

void Server::Shutdown() {
  scheduler_.Stop();
  engine_.Shutdown();
  if (grpc_server_ == nullptr) return;
  spdlog::info("shutting down: finishing in-flight calls");
  grpc_server_->Shutdown(std::chrono::system_clock::now() +
                         std::chrono::seconds(10));
  grpc_server_->Wait();
  grpc_server_.reset();
}

Server::~Server() { Shutdown(); }

}  // namespace hdrstereo::daemon
