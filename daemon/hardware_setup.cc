// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/hardware_setup.h"

#include <spdlog/spdlog.h>

#include <functional>

#include "absl/strings/str_cat.h"
#include "hardware/display/x11_projector.h"
#include "hardware/gphoto2/config_dump.h"
#include "hardware/gphoto2/gphoto2_camera.h"
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

// The configuration's names are checked when it is read (config.cc).
hardware::HardwareMode ModeOf(const Config& config) {
  return hardware::ParseHardwareMode(config.hardware)
      .value_or(hardware::HardwareMode::kReal);
}

hardware::RigConfig RigConfigOf(const Config& config) {
  return {.mode = ModeOf(config),
          .home_position_mm = config.home_position_mm,
          .max_baseline_mm = config.stage_travel_mm};
}

// The camera of a simulated rig, made once the world exists.
using CameraFactory =
    std::function<hardware::Slot<hardware::Camera>(sim::SimWorld&)>;

// An opened camera that is reopened with backoff when it drops; a camera
// that could not be opened at all stays absent (and says why).
hardware::Slot<hardware::Camera> Reconnecting(
    absl::StatusOr<std::unique_ptr<hardware::Camera>> camera,
    hardware::CameraOpener reopen) {
  if (!camera.ok()) return Slot<hardware::Camera>(camera.status(), "camera");
  hardware::ReconnectOptions options;
  options.on_change = [](const hardware::ConnectionState& state) {
    if (state.connected) {
      spdlog::info("camera: reconnected (drop {})", state.drops);
    } else {
      spdlog::warn("camera: {}", hardware::DescribeConnection(state));
    }
  };
  return {.device = std::make_unique<hardware::ReconnectingCamera>(
              *std::move(camera), std::move(reopen), std::move(options)),
          .error = {}};
}

// Reopens the gphoto2 camera `opened` is by its serial number (else its
// model), over apis from `new_api`.
hardware::CameraOpener Gphoto2Reopener(
    gphoto2::Gphoto2Options options, gphoto2::Gphoto2Camera& opened,
    gphoto2::Gphoto2Camera::ApiFactory new_api,
    std::function<absl::Status()> before = nullptr) {
  absl::StatusOr<hardware::CameraInfo> info = opened.Info();
  const std::string serial = info.ok() ? info->serial : "";
  options.model = opened.model();
  spdlog::info("camera: {} {}, reopened by {} if it drops", opened.model(),
               serial, serial.empty() ? "model" : "serial number");
  return [options, serial, new_api = std::move(new_api),
          before = std::move(
              before)]() -> absl::StatusOr<std::unique_ptr<hardware::Camera>> {
    if (before) {
      RETURN_IF_ERROR(before());
    }
    ASSIGN_OR_RETURN(std::unique_ptr<gphoto2::Gphoto2Camera> camera,
                     gphoto2::Gphoto2Camera::Reopen(options, serial, new_api));
    return std::unique_ptr<hardware::Camera>(std::move(camera));
  };
}

hardware::Slot<hardware::Camera> SimulatedCamera(sim::SimWorld& world) {
  return Reconnecting(
      std::make_unique<sim::SimCamera>(world, sim::SimCameraOptions{}),
      [&world]() -> absl::StatusOr<std::unique_ptr<hardware::Camera>> {
        RETURN_IF_ERROR(world.ReopenCamera());
        return std::make_unique<sim::SimCamera>(world, sim::SimCameraOptions{});
      });
}

// The real driver over a replay of `dump`; each capture is a frame the
// simulator renders at the shutter speed (and ISO) the driver chose among
// the replayed camera's choices, as JPEG or, for a RAW format, DNG; each
// live-view frame the simulator's preview at those settings.
hardware::Slot<hardware::Camera> ReplayedCamera(const Config& config,
                                                const gphoto2::CameraDump& dump,
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
  gphoto2::FrameSource previews = [&world](const hardware::ExposureSettings& s)
      -> absl::StatusOr<gphoto2::ReplayFile> {
    ASSIGN_OR_RETURN(sim::SimCapture preview,
                     world.Preview({.exposure_s = s.exposure_s,
                                    .iso = s.iso > 0 ? double(s.iso) : 100}));
    return gphoto2::ReplayFile{.bytes = std::move(preview.bytes),
                               .extension = "jpg"};
  };
  gphoto2::Gphoto2Options options;
  options.model = config.camera_model;
  spdlog::info("camera: replay of {} ({})", dump.source, dump.model);
  gphoto2::Gphoto2Camera::ApiFactory new_api = [dump, frames, previews] {
    return std::make_unique<gphoto2::ReplayApi>(dump, frames, previews);
  };
  absl::StatusOr<std::unique_ptr<gphoto2::Gphoto2Camera>> camera =
      gphoto2::Gphoto2Camera::OpenWithApi(options, new_api());
  if (!camera.ok()) return Slot<hardware::Camera>(camera.status(), "camera");
  // The replayed camera comes back when the simulated one does.
  hardware::CameraOpener reopen = Gphoto2Reopener(
      options, **camera, new_api, [&world] { return world.ReopenCamera(); });
  return Reconnecting(std::move(*camera), std::move(reopen));
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
  hardware::Slot<hardware::Camera> camera = make_camera(*hw->world);
  hardware::Slot<hardware::Projector> projector = Slot<hardware::Projector>(
      sim::SimProjector::Create(*hw->world), "projector");
  hw->rig =
      std::make_unique<hardware::Rig>(RigConfigOf(config), std::move(camera),
                                      std::move(stage), std::move(projector));
  return hw;
}

std::unique_ptr<Hardware> SetUpReal(const Config& config) {
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
  absl::StatusOr<std::unique_ptr<gphoto2::Gphoto2Camera>> camera =
      gphoto2::Gphoto2Camera::Open(camera_options);
  hardware::Slot<hardware::Camera> camera_slot;
  if (camera.ok()) {
    hardware::CameraOpener reopen = Gphoto2Reopener(
        camera_options, **camera, [] { return gphoto2::NewLibgphoto2Api(); });
    camera_slot = Reconnecting(std::move(*camera), std::move(reopen));
  } else {
    camera_slot = Slot<hardware::Camera>(camera.status(), "camera");
  }
  hw->rig = std::make_unique<hardware::Rig>(
      RigConfigOf(config), std::move(camera_slot),
      Slot<hardware::Stage>(zaber::ZaberStage::Open(zaber), "stage"),
      Slot<hardware::Projector>(display::X11Projector::Open(projector_options),
                                "projector"));
  return hw;
}

}  // namespace

absl::StatusOr<std::unique_ptr<Hardware>> SetUpHardware(const Config& config) {
  if (ModeOf(config) == hardware::HardwareMode::kSim) {
    return SetUpSimulation(config, &SimulatedCamera);
  }
  if (!config.camera_dump.empty()) {
    // A dump that cannot be read is a configuration error, like a bad scene.
    absl::StatusOr<gphoto2::CameraDump> dump =
        gphoto2::LoadCameraDump(config.camera_dump);
    if (!dump.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--camera-dump: ", dump.status().message()));
    }
    return SetUpSimulation(config, [&](sim::SimWorld& world) {
      return ReplayedCamera(config, *dump, world);
    });
  }
  return SetUpReal(config);
}

}  // namespace hdrstereo::daemon
