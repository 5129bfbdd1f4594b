// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <optional>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "daemon/jobs/capture_job.h"
#include "daemon/jobs/processing_job.h"
#include "daemon/rpc/call_guard.h"
#include "daemon/rpc/method_roles.h"
#include "daemon/rpc/server_credentials.h"
#include "hardware/sim/truth.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/pipeline/memory_estimate.h"

namespace hdrstereo::daemon {
namespace {

// The scheduler's clock runs `scheduler_clock_rate` times as fast as the
// wall clock from the daemon's start (1 = the wall clock; tests only); due
// runs wait while the rig is locked.
jobs::SchedulerOptions SchedulerOptionsFor(const Config& config,
                                           jobs::RigLock& rig_lock) {
  jobs::SchedulerOptions options;
  options.hold = [&rig_lock] { return rig_lock.CheckUnattended(); };
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
    ASSIGN_OR_RETURN(sim::StereoTruth truth,
                     world->Truth(left_mm, baseline_mm));
    return sim::WriteStereoTruth(truth, dir);
  };
}

// In simulation the operator continuing a calibration capture to a pose
// places the world's board there (a scene without board poses keeps it
// where it is).
jobs::BoardPlacer BoardPlacerFor(sim::SimWorld* world) {
  if (world == nullptr || world->scene().calibration_board.poses.empty()) {
    return nullptr;
  }
  return [world](int pose) { return world->PlaceBoard(pose); };
}

rpc::RoleMap UsersOf(const Config& config) {
  rpc::RoleMap users;
  for (const auto& [name, role] : config.users) {
    // ParseArgs has checked the names.
    users[name] = rpc::ParseRole(role).value_or(rpc::Role::kNone);
  }
  return users;
}

// The services hdrstereod registers (gRPC's health and reflection
// services have their rows in the table by name).
const std::vector<std::string>& ServedServices() {
  static const auto* const kServices = new std::vector<std::string>{
      v1::Server::service_full_name(),    v1::Sessions::service_full_name(),
      v1::Hardware::service_full_name(),  v1::Jobs::service_full_name(),
      v1::Schedules::service_full_name(), v1::Admin::service_full_name()};
  return *kServices;
}

// Physical memory, or the memory.max of the daemon's cgroup (v2: a
// systemd MemoryMax=, a container's limit) when lower.
int64_t MachineMemoryBytes() {
  int64_t bytes = static_cast<int64_t>(::sysconf(_SC_PHYS_PAGES)) *
                  static_cast<int64_t>(::sysconf(_SC_PAGE_SIZE));
  // "0::/system.slice/hdrstereod.service" names the v2 cgroup.
  absl::StatusOr<std::string> membership =
      io::ReadFileBytes("/proc/self/cgroup", 64 << 10, "cgroup membership");
  if (!membership.ok()) return bytes;
  for (absl::string_view line : absl::StrSplit(*membership, '\n')) {
    if (!absl::ConsumePrefix(&line, "0::")) continue;
    absl::StatusOr<std::string> limit =
        io::ReadFileBytes(absl::StrCat("/sys/fs/cgroup", line, "/memory.max"),
                          64, "a cgroup limit");
    int64_t cgroup = 0;
    if (limit.ok() &&
        absl::SimpleAtoi(absl::StripAsciiWhitespace(*limit), &cgroup) &&
        cgroup > 0) {
      bytes = std::min(bytes, cgroup);
    }
  }
  return bytes;
}

jobs::MemoryBudget MemoryBudgetFor(const Config& config) {
  // Both sizes were checked when the configuration was read; 0 = no limit.
  if (config.processing_backend == ProcessingBackend::kSlurm) {
    if (config.slurm.memory.empty()) return {};
    return {ParseMemorySize(config.slurm.memory).value_or(0),
            absl::StrCat("--slurm-memory ", config.slurm.memory)};
  }
  if (!config.processing_memory.empty()) {
    return {ParseMemorySize(config.processing_memory).value_or(0),
            absl::StrCat("--processing-memory ", config.processing_memory)};
  }
  const int64_t machine = MachineMemoryBytes();
  return {machine / std::max(1, config.processing_threads),
          absl::StrCat("this machine's ", pipeline::FormatBytes(machine),
                       " shared by --processing-threads ",
                       config.processing_threads)};
}

jobs::ProcessingEnvironment ProcessingEnvironmentFor(const Config& config) {
  jobs::ProcessingEnvironment environment;
  environment.threads = config.processing_threads;
  environment.memory = MemoryBudgetFor(config);
  if (config.processing_backend == ProcessingBackend::kSlurm) {
    environment.slurm = config.slurm;
  }
  if (config.hardware == hardware::HardwareMode::kSim) {
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

http::HttpEdgeOptions HttpOptionsFor(const Config& config) {
  http::HttpEdgeOptions options;
  options.listen = config.http_listen;
  options.hosts = config.http_hosts;
  options.sessions.idle_timeout =
      absl::Minutes(config.http_session_idle_minutes);
  options.sessions.lifetime = absl::Hours(config.http_session_lifetime_hours);
  options.max_connections = static_cast<size_t>(config.http_max_connections);
  options.max_body_bytes = static_cast<size_t>(config.http_max_body_kb) << 10;
  options.web_root_named = !config.web_root.empty();
  options.web_root =
      options.web_root_named ? config.web_root : http::DefaultWebRoot();
  return options;
}

notify::WebhookDispatcherOptions WebhookOptionsFor(const Config& config) {
  notify::WebhookDispatcherOptions options;
  options.retry.max_attempts = config.webhook_max_attempts;
  options.retry.first_retry = absl::Seconds(config.webhook_first_retry_s);
  options.request_timeout = absl::Seconds(config.webhook_timeout_s);
  return options;
}

}  // namespace

Server::Server(std::unique_ptr<store::Store> store,
               std::unique_ptr<Hardware> hardware,
               std::unique_ptr<jobs::RigLock> rig_lock,
               std::unique_ptr<rpc::ApiKeyStore> api_keys,
               notify::WebhookSigner signer, rpc::EdgeStamp edge_stamp,
               const Config& config)
    : store_(std::move(store)),
      hardware_(std::move(hardware)),
      rig_lock_(std::move(rig_lock)),
      api_keys_(std::move(api_keys)),
      webhook_signer_(std::move(signer)),
      authenticator_(
          UsersOf(config),
          rpc::ParseRole(config.local_role).value_or(rpc::Role::kNone),
          *api_keys_),
      audit_log_(*store_),
      edge_stamp_(std::move(edge_stamp)),
      processing_(ProcessingEnvironmentFor(config)),
      engine_(
          *store_,
          [rig = hardware_->rig.get(),
           truth = TruthWriterFor(hardware_->world.get()),
           place_board = BoardPlacerFor(hardware_->world.get()),
           conditions =
               jobs::CaptureConditions{
                   .disk = &disk_guard_,
                   .min_battery_percent = config.min_battery_percent}](
              jobs::JobContext& context) {
            return jobs::RunCaptureJob(*rig, context, truth, conditions,
                                       place_board);
          },
          [rig = hardware_->rig.get(),
           environment = &processing_](jobs::JobContext& context) {
            return jobs::RunProcessingJob(*rig, *environment, context);
          },
          // On Slurm a pool thread only follows its batch job.
          {.processing_threads =
               config.processing_backend == ProcessingBackend::kSlurm
                   ? config.max_cluster_jobs
                   : config.processing_threads,
           .resume_interrupted = config.resume_interrupted}),
      webhooks_(*store_, webhook_signer_, engine_, WebhookOptionsFor(config)),
      disk_guard_(*store_,
                  {.margin_bytes = config.disk_margin_mb << 20,
                   .processing_headroom = 1.0,
                   .frame_bytes_guess = config.frame_bytes_guess_mb << 20}),
      server_service_(*store_, disk_guard_, call_decisions_,
                      hardware::HardwareModeName(config.hardware), absl::Now()),
      sessions_service_(*store_, call_decisions_),
      hardware_service_(*hardware_->rig, *rig_lock_, call_decisions_, engine_),
      jobs_service_(engine_, *hardware_->rig, processing_, disk_guard_,
                    call_decisions_),
      scheduler_(
          *store_,
          [this](absl::string_view session, const v1::CapturePlan& plan,
                 absl::string_view by) -> absl::StatusOr<int64_t> {
            ASSIGN_OR_RETURN(
                store::JobRecord job,
                jobs::SubmitCapture(engine_, *hardware_->rig, session, plan, by,
                                    &disk_guard_));
            return job.id;
          },
          [this](absl::string_view session,
                 const std::vector<std::string>& steps,
                 absl::string_view by) -> absl::StatusOr<int64_t> {
            v1::SubmitProcessingRequest request;
            request.set_session(std::string(session));
            for (const std::string& step : steps) request.add_steps(step);
            ASSIGN_OR_RETURN(store::JobRecord job,
                             jobs::SubmitProcessing(engine_, *hardware_->rig,
                                                    processing_, request, by));
            return job.id;
          },
          SchedulerOptionsFor(config, *rig_lock_)),
      schedules_service_(scheduler_, *hardware_->rig, call_decisions_),
      admin_service_(call_decisions_, authenticator_, *api_keys_, audit_log_,
                     *store_, webhook_signer_) {}

absl::StatusOr<std::unique_ptr<Server>> Server::Start(const Config& config) {
  if (std::vector<std::string> missing =
          rpc::MethodsWithoutRule(ServedServices());
      !missing.empty()) {
    return absl::InternalError(absl::StrCat("no role table entry for ",
                                            absl::StrJoin(missing, ", "),
                                            " (daemon/rpc/method_roles.cc)"));
  }
  // TLS files first: a bad one is refused before anything is opened.
  std::optional<rpc::TlsMaterial> tls;
  if (config.tls.enabled()) {
    ASSIGN_OR_RETURN(tls, rpc::LoadTlsMaterial(config.tls));
  }
  ASSIGN_OR_RETURN(std::unique_ptr<store::Store> store,
                   store::Store::Open(config.data_root));
  spdlog::info("data root {} (schema version {})",
               store->files().root().string(), store->schema_version());

  ASSIGN_OR_RETURN(std::unique_ptr<Hardware> hardware, SetUpHardware(config));
  ASSIGN_OR_RETURN(std::unique_ptr<jobs::RigLock> rig_lock,
                   jobs::RigLock::Load(*store));
  ASSIGN_OR_RETURN(std::unique_ptr<rpc::ApiKeyStore> api_keys,
                   rpc::ApiKeyStore::Load(*store));
  ASSIGN_OR_RETURN(notify::WebhookSigner signer,
                   notify::WebhookSigner::Open(store->files().root()));
  ASSIGN_OR_RETURN(rpc::EdgeStamp edge_stamp, rpc::EdgeStamp::Create());
  std::unique_ptr<Server> server(new Server(
      std::move(store), std::move(hardware), std::move(rig_lock),
      std::move(api_keys), std::move(signer), std::move(edge_stamp), config));
  // Before the jobs start: a taken metrics port fails the start, naming it.
  if (!config.metrics_listen.empty()) {
    ASSIGN_OR_RETURN(
        server->metrics_,
        metrics::MetricsExporter::Start(config.metrics_listen, *server->store_,
                                        server->disk_guard_));
    spdlog::info(
        "serving metrics on http://{}:{}/metrics",
        config.metrics_listen.substr(0, config.metrics_listen.rfind(':')),
        server->metrics_->port());
  }
  RETURN_IF_ERROR(server->engine_.Start());
  // After the engine, whose start-up events (interrupted jobs) it reports.
  RETURN_IF_ERROR(server->webhooks_.Start());
  RETURN_IF_ERROR(server->scheduler_.Start());
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  auto guard = std::make_shared<rpc::CallGuard>(
      server->authenticator_, *server->rig_lock_, server->audit_log_);
  std::vector<int> ports(config.listen.size(), 0);
  for (size_t i = 0; i < config.listen.size(); ++i) {
    builder.AddListeningPort(
        config.listen[i],
        rpc::ServerCredentialsFor(config.listen[i], tls ? &*tls : nullptr,
                                  guard),
        &ports[i]);
  }
  std::vector<
      std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>>
      interceptors;
  // The guard every call runs, in-process calls too; CallGuard above also
  // guards the network ports' health and reflection services.
  interceptors.push_back(std::make_unique<rpc::CallGuardInterceptorFactory>(
      guard, server->edge_stamp_, server->audit_log_, server->call_decisions_));
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  builder.RegisterService(&server->server_service_);
  builder.RegisterService(&server->sessions_service_);
  builder.RegisterService(&server->hardware_service_);
  builder.RegisterService(&server->jobs_service_);
  builder.RegisterService(&server->schedules_service_);
  builder.RegisterService(&server->admin_service_);
  server->grpc_server_ = builder.BuildAndStart();
  std::vector<std::string> described;
  for (size_t i = 0; i < config.listen.size(); ++i) {
    const std::string& listen = config.listen[i];
    if (server->grpc_server_ == nullptr || ports[i] == 0) {
      return absl::UnavailableError(
          absl::StrCat("cannot listen on ", listen, " (address in use?)"));
    }
    if (listen.starts_with("unix:")) {
      server->addresses_.push_back(listen);
      // Whoever may connect is local with --local-role: members of the
      // socket's group (hdrstereo, as installed), not every user.
      const std::string path = listen.substr(listen.find(':') + 1);
      if (::chmod(path.c_str(), 0660) != 0) {
        spdlog::warn("cannot make {} mode 0660: {}", path, strerror(errno));
      }
    } else {
      server->addresses_.push_back(
          absl::StrCat(listen.substr(0, listen.rfind(':')), ":", ports[i]));
    }
    described.push_back(
        IsLocalAddress(listen)
            ? absl::StrCat(server->addresses_.back(), " (local, role ",
                           config.local_role, ")")
            : absl::StrCat(server->addresses_.back(), " (TLS)"));
  }
  spdlog::info("serving gRPC on {}", absl::StrJoin(described, ", "));
  std::vector<std::string> ready = server->addresses_;
  if (!config.http_listen.empty()) {
    absl::StatusOr<std::unique_ptr<http::HttpEdge>> edge =
        http::HttpEdge::Start(HttpOptionsFor(config), tls ? &*tls : nullptr,
                              {.channel = server->InProcessChannel(),
                               .stamp = &server->edge_stamp_,
                               .keys = server->api_keys_.get(),
                               .authenticator = &server->authenticator_,
                               .audit = &server->audit_log_});
    if (!edge.ok()) {
      server->Shutdown();
      return edge.status();
    }
    server->http_ = std::move(*edge);
    const char* scheme = tls ? "https://" : "http://";
    for (const std::string& address : server->http_->addresses()) {
      ready.push_back(absl::StrCat(scheme, address));
    }
    spdlog::info(
        "serving HTTP on {} (the console at /; every other request needs "
        "credentials)",
        absl::StrJoin(server->http_->addresses(), ", "));
  }
  if (!config.ready_file.empty()) {
    // The gRPC addresses, then the HTTP edge's base URLs.
    if (absl::Status s = io::WriteFileAtomically(
            config.ready_file, absl::StrCat(absl::StrJoin(ready, "\n"), "\n"));
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
  // Events recorded after its last pass are sent after the next start: the
  // outbox's cursor is in SQLite.
  webhooks_.Stop();
  if (grpc_server_ == nullptr) return;
  spdlog::info("shutting down: finishing in-flight calls");
  grpc_server_->Shutdown(std::chrono::system_clock::now() +
                         std::chrono::seconds(10));
  grpc_server_->Wait();
  // After the services: the in-process calls it made have ended with them.
  if (http_ != nullptr) http_->Stop();
  grpc_server_.reset();
}

std::shared_ptr<grpc::Channel> Server::InProcessChannel() {
  if (grpc_server_ == nullptr) return nullptr;
  return grpc_server_->InProcessChannel(grpc::ChannelArguments());
}

Server::~Server() { Shutdown(); }

}  // namespace hdrstereo::daemon
