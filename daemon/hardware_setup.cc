// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/hardware_setup.h"

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "hardware/display/x11_projector.h"
#include "hardware/gphoto2/gphoto2_camera.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_devices.h"
#include "hardware/zaber/zaber_stage.h"

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

absl::StatusOr<std::unique_ptr<Hardware>> SetUpSimulation(
    const Config& config) {
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
  absl::StatusOr<std::unique_ptr<sim::StageEmulator>> emulator =
      sim::StageEmulator::Start(stage_options, hw->world.get());
  if (!emulator.ok()) return emulator.status();
  hw->emulator = *std::move(emulator);
  spdlog::info("simulated scene {}; stage emulated on {}", scene->name,
               hw->emulator->device_path());

  zaber::ZaberOptions zaber;
  zaber.port = hw->emulator->device_path();
  zaber.microstep_um = stage_options.microstep_um;
  zaber.travel_mm = stage_options.travel_mm;
  hardware::Slot<hardware::Stage> stage =
      Slot<hardware::Stage>(zaber::ZaberStage::Open(zaber), "stage");
  hardware::Slot<hardware::Camera> camera = {
      .device =
          std::make_unique<sim::SimCamera>(*hw->world, sim::SimCameraOptions{}),
      .error = {}};
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
  hw->rig = std::make_unique<hardware::Rig>(
      RigConfigOf(config),
      Slot<hardware::Camera>(gphoto2::Gphoto2Camera::Open(camera_options),
                             "camera"),
      Slot<hardware::Stage>(zaber::ZaberStage::Open(zaber), "stage"),
      Slot<hardware::Projector>(display::X11Projector::Open(projector_options),
                                "projector"));
  return hw;
}

}  // namespace

absl::StatusOr<std::unique_ptr<Hardware>> SetUpHardware(const Config& config) {
  if (ModeOf(config) == hardware::HardwareMode::kSim) {
    return SetUpSimulation(config);
  }
  return SetUpReal(config);
}

}  // namespace hdrstereo::daemon
