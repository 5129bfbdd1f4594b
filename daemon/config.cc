// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/config.h"

#include <CLI/CLI.hpp>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "hdrstereo_version.h"

namespace hdrstereo::daemon {

absl::Status ValidateListenAddress(const std::string& address) {
  if (absl::StartsWith(address, "unix:")) {
    if (address.size() > 5) return absl::OkStatus();
    return absl::InvalidArgumentError("--listen unix: needs a socket path");
  }
  size_t colon = address.rfind(':');
  if (colon == std::string::npos) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--listen \"", address, "\" must be HOST:PORT or unix:PATH"));
  }
  std::string host = address.substr(0, colon);
  int port = 0;
  if (!absl::SimpleAtoi(address.substr(colon + 1), &port) || port < 0 ||
      port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("--listen \"", address, "\" has no valid port (0-65535)"));
  }
  if (host == "localhost" || host == "[::1]" ||
      absl::StartsWith(host, "127.")) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "--listen \"", address,
      "\" is not a loopback address; remote access needs TLS and client "
      "authentication, which this version does not offer: listen on "
      "127.0.0.1 or a unix socket and tunnel (e.g. ssh -L)"));
}

absl::StatusOr<ParsedArgs> ParseArgs(int argc, const char* const* argv) {
  Config config;
  CLI::App app{"hdrstereod: HDR stereo acquisition daemon", "hdrstereod"};
  app.set_version_flag("--version", HDRSTEREO_VERSION);
  app.set_config("--config", "", "Read options from a TOML file")
      ->check(CLI::ExistingFile);
  app.allow_config_extras(false);
  app.add_option("--listen", config.listen,
                 "Address to serve gRPC on: HOST:PORT (loopback) or unix:PATH")
      ->capture_default_str();
  app.add_option("--data-root", config.data_root,
                 "Folder holding hdrstereo.db and the session folders")
      ->capture_default_str();
  app.add_option("--hardware", config.hardware, "Devices to drive")
      ->check(CLI::IsMember({"sim", "real"}))
      ->capture_default_str();
  app.add_option("--log-file", config.log_file,
                 "Rotating log file [default: DATA_ROOT/logs/hdrstereod.log]");
  app.add_option("--log-level", config.log_level, "Console and file log level")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
  app.add_option("--ready-file", config.ready_file,
                 "Write the bound address here once serving");
  app.add_option("--processing-threads", config.processing_threads,
                 "Processing jobs run in parallel")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--resume-interrupted", config.resume_interrupted,
                 "Resume jobs a stop interrupted")
      ->capture_default_str();
  app.add_option("--scheduler-clock-rate", config.scheduler_clock_rate,
                 "Test only: scheduler clock speed relative to the wall clock")
      ->check(CLI::Range(1.0, 100000.0))
      ->capture_default_str();
  app.add_option("--home-position-mm", config.home_position_mm,
                 "Stage position of the left view")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--camera-model", config.camera_model,
                 "libgphoto2 camera model [default: first found]");
  app.add_option("--camera-port", config.camera_port,
                 "libgphoto2 port, e.g. usb:001,004");
  app.add_option("--camera-dump", config.camera_dump,
                 "With --hardware real: replay this `gphoto2 --summary "
                 "--list-all-config` dump as the camera (frames, stage and "
                 "projector simulated from --sim-scene)")
      ->check(CLI::ExistingFile);
  app.add_option("--stage-port", config.stage_port, "Zaber serial port")
      ->capture_default_str();
  app.add_option("--stage-device", config.stage_device, "Zaber device number")
      ->check(CLI::Range(1, 99))
      ->capture_default_str();
  app.add_option("--stage-axis", config.stage_axis, "Zaber axis number")
      ->check(CLI::Range(1, 9))
      ->capture_default_str();
  app.add_option("--stage-travel-mm", config.stage_travel_mm, "Stage travel")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--stage-microstep-um", config.stage_microstep_um,
                 "Distance of one microstep")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--projector-display", config.projector_display,
                 "X display of the projector [default: $DISPLAY]");
  app.add_option("--projector-x", config.projector_x, "Projector left edge");
  app.add_option("--projector-y", config.projector_y, "Projector top edge");
  app.add_option("--projector-width", config.projector_width,
                 "Projector width in pixels [default: screen]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--projector-height", config.projector_height,
                 "Projector height in pixels [default: screen]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--projector-settle-s", config.projector_settle_s,
                 "Wait after showing a pattern")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  app.add_option("--sim-scene", config.sim_scene,
                 "Simulated scene: bundled name or JSON file")
      ->capture_default_str();
  app.add_option("--sim-time-scale", config.sim_time_scale,
                 "Simulated hardware time: 0 = instant, 1 = real time")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForVersion&) {
    return ParsedArgs(
        ExitWithText{absl::StrCat("hdrstereod ", HDRSTEREO_VERSION)});
  } catch (const CLI::Success&) {
    return ParsedArgs(ExitWithText{app.help()});
  } catch (const CLI::ParseError& e) {
    return absl::InvalidArgumentError(e.what());
  }
  if (absl::Status s = ValidateListenAddress(config.listen); !s.ok()) return s;
  if (!config.camera_dump.empty() && config.hardware != "real") {
    return absl::InvalidArgumentError(
        "--camera-dump replays a real camera for the real camera driver: "
        "use it with --hardware real");
  }
  if (config.log_file.empty()) {
    config.log_file = config.data_root / "logs" / "hdrstereod.log";
  }
  return ParsedArgs(std::move(config));
}

}  // namespace hdrstereo::daemon
