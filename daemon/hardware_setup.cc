// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/hardware_setup.h"

#include <spdlog/spdlog.h>

#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "hardware/display/x11_projector.h"
#include "hardware/gphoto2/config_dump.h"
#include "hardware/gphoto2/gphoto2_camera.h"
#include "hardware/gphoto2/gphoto2_opener.h"
#include "hardware/gphoto2/libgphoto2_api.h"
#include "hardware/gphoto2/replay_api.h"
#include "hardware/reconnecting_camera.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_devices.h"
#include "hardware/zaber/zaber_stage.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::daemon {
namespace {

template <typename Device>
hardware::Slot<Device> Slot(absl::StatusOr<std::unique_ptr<Device>> device,
                            absl::string_view what) {
  if (device.ok()) return {.device = *std::move(device), .error = {}};
  spdlog::warn("{} unavailable: {}", std::string(what),
               std::string(device.status().message()));
  return {.device = nullptr, .error = device.status()};
}

hardware::RigConfig RigConfigOf(const Config& config) {
  return {.mode = config.hardware,
          .home_position_mm = config.home_position_mm,
          .max_baseline_mm = config.stage_travel_mm};
}

// The camera of a simulated rig, made once the world exists (in `hw`,
// which also keeps what the camera needs).
using CameraFactory =
    std::function<absl::StatusOr<hardware::Slot<hardware::Camera>>(
        Hardware& hw)>;

// The camera `first` is (as `open` first opened it, or why it could not
// be), reopened by `open` with the configured backoff whenever it is away:
// after a drop, and from the start when it was not there.
hardware::Slot<hardware::Camera> Reconnecting(
    const Config& config,
    absl::StatusOr<std::unique_ptr<hardware::Camera>> first,
    hardware::CameraOpener open) {
  if (!first.ok()) {
    spdlog::warn("camera: not there at the start ({}); looking for it",
                 std::string(first.status().message()));
  }
  hardware::ReconnectOptions options;
  options.initial_backoff = absl::Seconds(config.camera_reconnect_first_s);
  options.max_backoff = absl::Seconds(config.camera_reconnect_max_s);
  options.on_change = [](const hardware::ConnectionState& state) {
    if (!state.connected) {
      spdlog::warn("camera: {}", hardware::DescribeConnection(state));
    } else if (state.drops == 0) {
      spdlog::info("camera: found");
    } else {
      spdlog::info("camera: reconnected (drop {})", state.drops);
    }
  };
  return {.device = std::make_unique<hardware::ReconnectingCamera>(
              std::move(first), std::move(open), std::move(options)),
          .error = {}};
}

// The gphoto2 camera `options` name, over apis from `new_api`. A first open
// that fails with NOT_FOUND (libgphoto2, or the replay, knows no such model;
// no such port) fails the start: that configuration never finds a camera.
// Any other failure (none found, another model on the bus, USB claimed,
// no answer) is a camera that is not there yet: the daemon starts and
// looks for it.
absl::StatusOr<hardware::Slot<hardware::Camera>> Gphoto2Slot(
    const Config& config, const gphoto2::Gphoto2Options& options,
    gphoto2::Gphoto2Camera::ApiFactory new_api) {
  auto opener =
      std::make_shared<gphoto2::Gphoto2Opener>(options, std::move(new_api));
  hardware::CameraOpener open = gphoto2::CameraOpenerOf(opener);
  absl::StatusOr<std::unique_ptr<hardware::Camera>> first = open();
  if (absl::IsNotFound(first.status())) {
    std::string configured;
    if (!options.model.empty()) {
      absl::StrAppend(&configured, " --camera-model \"", options.model, "\"");
    }
    if (!options.port.empty()) {
      absl::StrAppend(&configured, " --camera-port \"", options.port, "\"");
    }
    return absl::InvalidArgumentError(absl::StrCat(
        "no camera can match", configured, ": ", first.status().message()));
  }
  if (first.ok()) {
    spdlog::info("camera: {} {}, reopened by {} if it drops", opener->model(),
                 opener->serial(),
                 opener->serial().empty() ? "model" : "serial number");
  }
  return Reconnecting(config, std::move(first), std::move(open));
}

absl::StatusOr<hardware::Slot<hardware::Camera>> SimulatedCamera(
    const Config& config, sim::SimWorld& world) {
  hardware::CameraOpener open =
      [&world]() -> absl::StatusOr<std::unique_ptr<hardware::Camera>> {
    RETURN_IF_ERROR(world.ReopenCamera());
    return std::make_unique<sim::SimCamera>(world, sim::SimCameraOptions{});
  };
  absl::StatusOr<std::unique_ptr<hardware::Camera>> first = open();
  return Reconnecting(config, std::move(first), std::move(open));
}

// The real gphoto2 driver, through libgphoto2, to the world's camera
// served as a PTP/IP camera on a free loopback port (kept in hw).
absl::StatusOr<hardware::Slot<hardware::Camera>> PtpIpSimulatedCamera(
    const Config& config, Hardware& hw) {
  const std::optional<hardware::ImageFormat> format =
      hardware::ParseImageFormat(config.sim_camera_format);
  if (!format.has_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--sim-camera-format ", config.sim_camera_format,
                     " is not png8, tiff16, jpeg or raw"));
  }
  sim::PtpIpCameraOptions responder;
  responder.format = sim::SimFormatOf(*format);
  ASSIGN_OR_RETURN(hw.ptpip_camera,
                   sim::PtpIpCamera::Start(*hw.world, responder));
  spdlog::info("simulated camera: PTP/IP on {}",
               hw.ptpip_camera->gphoto2_port());
  gphoto2::Gphoto2Options options;
  options.model = sim::PtpIpCamera::kGphoto2Model;
  options.port = hw.ptpip_camera->gphoto2_port();
  options.fixed_format = *format;
  return Gphoto2Slot(config, options,
                     [] { return gphoto2::NewLibgphoto2Api(); });
}

// The real driver over a replay of `dump`; each capture is a frame the
// simulator renders at the shutter speed (and ISO) the driver chose among
// the replayed camera's choices, as JPEG or, for a RAW format, DNG; each
// live-view frame the simulator's preview at those settings. The replayed
// camera is on its (replayed) USB link while the simulated one is
// connected: the simulator's disconnect fault unplugs it mid-capture, and
// it is found again when the simulator lets its camera be reopened.
absl::StatusOr<hardware::Slot<hardware::Camera>> ReplayedCamera(
    const Config& config, const gphoto2::CameraDump& dump,
    sim::SimWorld& world) {
  gphoto2::FrameSource frames = [&world](const hardware::ExposureSettings& s)
      -> absl::StatusOr<gphoto2::ReplayFile> {
    const bool raw = s.format == hardware::ImageFormat::kRaw ||
                     s.format == hardware::ImageFormat::kRawAndJpeg;
    ASSIGN_OR_RETURN(
        sim::SimCapture capture,
        world.Capture({.exposure_s = s.exposure_s,
                       .iso = s.iso > 0 ? double(s.iso) : 100},
                      raw ? sim::ImageFormat::kDng : sim::ImageFormat::kJpeg));
    return gphoto2::ReplayFile{.bytes = std::move(capture.bytes),
                               .extension = raw ? "dng" : "jpg"};
  };
  // Live view: the simulator's preview at the settings the driver chose.
  gphoto2::FrameSource previews = [&world](const hardware::ExposureSettings& s)
      -> absl::StatusOr<gphoto2::ReplayFile> {
    ASSIGN_OR_RETURN(sim::SimCapture preview,
                     world.Preview({.exposure_s = s.exposure_s,
                                    .iso = s.iso > 0 ? double(s.iso) : 100}));
    return gphoto2::ReplayFile{.bytes = std::move(preview.bytes),
                               .extension = "jpg"};
  };
  auto link = std::make_shared<gphoto2::ReplayLink>(
      [&world] { return world.ReopenCamera(); });
  gphoto2::Gphoto2Options options;
  options.model = config.camera_model;
  spdlog::info("camera: replay of {} ({})", dump.source, dump.model);
  return Gphoto2Slot(config, options, [dump, frames, link, previews] {
    return std::make_unique<gphoto2::ReplayApi>(dump, frames, link, previews);
  });
}

absl::StatusOr<std::unique_ptr<Hardware>> SetUpSimulation(
    const Config& config, const CameraFactory& make_camera) {
  absl::StatusOr<sim::Scene> scene = sim::LoadScene(config.sim_scene);
  if (!scene.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--sim-scene ", config.sim_scene, ": ", scene.status().message()));
  }
  scene->timing.scale = config.sim_time_scale;
  auto hw = std::make_unique<Hardware>();
  hw->world = std::make_unique<sim::SimWorld>(*scene);

  sim::StageEmulatorOptions stage_options =
      sim::StageEmulatorOptions::FromScene(*scene);
  ASSIGN_OR_RETURN(std::unique_ptr<sim::StageEmulator> emulator,
                   sim::StageEmulator::Start(stage_options, hw->world.get()));
  hw->emulator = std::move(emulator);
  spdlog::info("simulated scene {}; stage emulated on {}", scene->name,
               hw->emulator->device_path());

  zaber::ZaberOptions zaber;
  zaber.port = hw->emulator->device_path();
  zaber.microstep_um = stage_options.microstep_um;
  zaber.travel_mm = stage_options.travel_mm;
  hardware::Slot<hardware::Stage> stage =
      Slot<hardware::Stage>(zaber::ZaberStage::Open(zaber), "stage");
  ASSIGN_OR_RETURN(hardware::Slot<hardware::Camera> camera, make_camera(*hw));
  hardware::Slot<hardware::Projector> projector = Slot<hardware::Projector>(
      sim::SimProjector::Create(*hw->world), "projector");
  hw->rig =
      std::make_unique<hardware::Rig>(RigConfigOf(config), std::move(camera),
                                      std::move(stage), std::move(projector));
  return hw;
}

absl::StatusOr<std::unique_ptr<Hardware>> SetUpReal(const Config& config) {
  auto hw = std::make_unique<Hardware>();
  gphoto2::Gphoto2Options camera_options;
  camera_options.model = config.camera_model;
  camera_options.port = config.camera_port;
  zaber::ZaberOptions zaber;
  zaber.port = config.stage_port;
  zaber.device = config.stage_device;
  zaber.axis = config.stage_axis;
  zaber.travel_mm = config.stage_travel_mm;
  zaber.microstep_um = config.stage_microstep_um;
  display::X11ProjectorOptions projector_options{
      .display = config.projector_display,
      .x = config.projector_x,
      .y = config.projector_y,
      .width_px = config.projector_width,
      .height_px = config.projector_height,
      .settle_time = absl::Seconds(config.projector_settle_s)};
  ASSIGN_OR_RETURN(hardware::Slot<hardware::Camera> camera_slot,
                   Gphoto2Slot(config, camera_options,
                               [] { return gphoto2::NewLibgphoto2Api(); }));
  hw->rig = std::make_unique<hardware::Rig>(
      RigConfigOf(config), std::move(camera_slot),
      Slot<hardware::Stage>(zaber::ZaberStage::Open(zaber), "stage"),
      Slot<hardware::Projector>(display::X11Projector::Open(projector_options),
                                "projector"));
  return hw;
}

}  // namespace

absl::StatusOr<std::unique_ptr<Hardware>> SetUpHardware(const Config& config) {
  if (config.hardware == hardware::HardwareMode::kSim) {
    return SetUpSimulation(config, [&config](Hardware& hw) {
      if (config.sim_camera == "ptpip") return PtpIpSimulatedCamera(config, hw);
      return SimulatedCamera(config, *hw.world);
    });
  }
  if (!config.camera_dump.empty()) {
    // A dump that cannot be read is a configuration error, like a bad scene.
    absl::StatusOr<gphoto2::CameraDump> dump =
        gphoto2::LoadCameraDump(config.camera_dump);
    if (!dump.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--camera-dump: ", dump.status().message()));
    }
    return SetUpSimulation(config, [&](Hardware& hw) {
      return ReplayedCamera(config, *dump, *hw.world);
    });
  }
  return SetUpReal(config);
}

}  // namespace hdrstereo::daemon
