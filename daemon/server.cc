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
#include "daemon/jobs/processing_job.h"
#include "hardware/sim/truth.h"
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

// In simulation a finished stereo capture gets the world's exact truth.
jobs::TruthWriter TruthWriterFor(const sim::SimWorld* world) {
  if (world == nullptr) return nullptr;
  return [world](double left_mm, double baseline_mm,
                 const std::filesystem::path& dir) -> absl::Status {
    absl::StatusOr<sim::StereoTruth> truth = world->Truth(left_mm, baseline_mm);
    if (!truth.ok()) return truth.status();
    return sim::WriteStereoTruth(*truth, dir);
  };
}

jobs::ProcessingEnvironment ProcessingEnvironmentFor(const Config& config) {
  jobs::ProcessingEnvironment environment;
  environment.threads = config.processing_threads;
  if (config.hardware == "sim") {
    environment.summary.emplace_back(
        "hardware", absl::StrCat("simulated (scene ", config.sim_scene,
                                 "), Zaber stage emulated on a pty"));
  } else {
    environment.summary.emplace_back(
        "hardware",
        absl::StrCat(
            "camera ",
            config.camera_model.empty() ? "(first found)" : config.camera_model,
            ", Zaber stage on ", config.stage_port, ", projector on ",
            config.projector_display.empty() ? "$DISPLAY"
                                             : config.projector_display));
  }
  return environment;
}

}  // namespace

Server::Server(std::unique_ptr<store::Store> store,
               std::unique_ptr<Hardware> hardware, const Config& config)
    : store_(std::move(store)),
      hardware_(std::move(hardware)),
      engine_(
          *store_,
          [rig = hardware_->rig.get(),
           truth = TruthWriterFor(hardware_->world.get())](
              jobs::JobContext& context) {
            return jobs::RunCaptureJob(*rig, context, truth);
          },
          [rig = hardware_->rig.get(), environment = ProcessingEnvironmentFor(
                                           config)](jobs::JobContext& context) {
            return jobs::RunProcessingJob(*rig, environment, context);
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
          [this](absl::string_view session,
                 const std::vector<std::string>& steps)
              -> absl::StatusOr<int64_t> {
            v1::SubmitProcessingRequest request;
            request.set_session(std::string(session));
            for (const std::string& step : steps) request.add_steps(step);
            absl::StatusOr<store::JobRecord> job =
                jobs::SubmitProcessing(engine_, *hardware_->rig, request);
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
