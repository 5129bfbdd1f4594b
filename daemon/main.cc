// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereod: parses the configuration, sets up logging, serves until
// SIGINT or SIGTERM, then shuts down cleanly. SIGHUP (systemd's ExecReload)
// re-reads the configuration: the log level takes effect at once; any other
// changed option is reported and needs a restart.
#include <fcntl.h>
#include <signal.h>
#include <spdlog/sinks/rotating_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <iostream>
#include <memory>

#include "daemon/config.h"
#include "daemon/server.h"
#include "hdrstereo_version.h"
#include "processing/pipeline/memory_estimate.h"

namespace {

constexpr size_t kLogFileBytes = 10 * 1024 * 1024;
constexpr size_t kLogFiles = 5;

bool SetUpLogging(const hdrstereo::daemon::Config& config) {
  try {
    std::filesystem::create_directories(config.log_file.parent_path());
    auto console = std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
    auto file = std::make_shared<spdlog::sinks::rotating_file_sink_mt>(
        config.log_file.string(), kLogFileBytes, kLogFiles);
    auto logger = std::make_shared<spdlog::logger>(
        "hdrstereod", spdlog::sinks_init_list{console, file});
    logger->set_level(spdlog::level::from_str(config.log_level));
    logger->flush_on(spdlog::level::info);
    spdlog::set_default_logger(logger);
    return true;
  } catch (const std::exception& e) {
    std::cerr << "hdrstereod: cannot open log file " << config.log_file << ": "
              << e.what() << "\n";
    return false;
  }
}

// Started with standard descriptors closed, the daemon would hand 0, 1 or
// 2 to its database or sockets, which then get stdio written to them (or,
// for 0, closed by libgphoto2's PTP/IP code: libgphoto2_api.cc).
void OpenStandardDescriptors() {
  for (int fd = 0; fd <= 2; ++fd) {
    if (fcntl(fd, F_GETFD) == -1 && open("/dev/null", O_RDWR) == -1) return;
  }
}

}  // namespace

int main(int argc, char** argv) {
  OpenStandardDescriptors();
  // Processing jobs run the pipeline in this process.
  hdrstereo::pipeline::ReturnFreedImagesToTheSystem();
  absl::StatusOr<hdrstereo::daemon::ParsedArgs> parsed =
      hdrstereo::daemon::ParseArgs(argc, argv);
  if (!parsed.ok()) {
    std::cerr << "hdrstereod: " << parsed.status().message() << "\n";
    return 2;
  }
  if (auto* text = std::get_if<hdrstereo::daemon::ExitWithText>(&*parsed)) {
    std::cout << text->text << "\n";
    return 0;
  }
  const auto& config = std::get<hdrstereo::daemon::Config>(*parsed);

  // Signals are taken synchronously by sigwait below; block them before any
  // thread starts so that gRPC's threads inherit the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  if (!SetUpLogging(config)) return 1;
  spdlog::info("hdrstereod {} starting (hardware: {})", HDRSTEREO_VERSION,
               hdrstereo::hardware::HardwareModeName(config.hardware));

  absl::StatusOr<std::unique_ptr<hdrstereo::daemon::Server>> server =
      hdrstereo::daemon::Server::Start(config);
  if (!server.ok()) {
    spdlog::error("cannot start: {}", std::string(server.status().message()));
    return 1;
  }

  int signal_number = 0;
  while (true) {
    sigwait(&signals, &signal_number);
    if (signal_number != SIGHUP) break;
    absl::StatusOr<hdrstereo::daemon::ParsedArgs> reread =
        hdrstereo::daemon::ParseArgs(argc, argv);
    if (!reread.ok() ||
        !std::holds_alternative<hdrstereo::daemon::Config>(*reread)) {
      spdlog::error("reload: configuration refused, keeping the old one: {}",
                    reread.ok() ? std::string("not a configuration")
                                : std::string(reread.status().message()));
      continue;
    }
    const auto& fresh = std::get<hdrstereo::daemon::Config>(*reread);
    spdlog::default_logger()->set_level(
        spdlog::level::from_str(fresh.log_level));
    spdlog::info(
        "reload: log level {}; other changed options take effect "
        "at the next restart",
        fresh.log_level);
  }
  spdlog::info("received {}", strsignal(signal_number));
  (*server)->Shutdown();
  server->reset();
  spdlog::info("stopped");
  return 0;
}
