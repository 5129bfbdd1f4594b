// SPDX-License-Identifier: GPL-3.0-or-later
//
// The hardware interfaces over the simulated world: a camera that renders
// the world at the stage's current position, and a projector whose pattern
// lights the world. (The simulated stage is the real Zaber driver talking to
// StageEmulator on a pseudo-terminal.)
#ifndef HDRSTEREO_HARDWARE_SIM_SIM_DEVICES_H_
#define HDRSTEREO_HARDWARE_SIM_SIM_DEVICES_H_

#include <mutex>

#include "hardware/camera.h"
#include "hardware/projector.h"
#include "hardware/sim/sim_world.h"

namespace hdrstereo::sim {

struct SimCameraOptions {
  hardware::ImageFormat format = hardware::ImageFormat::kPng8;
  // "Camera busy" is retried like the real driver does: this many times,
  // with doubling waits from `busy_backoff`.
  int busy_retries = 5;
  absl::Duration busy_backoff = absl::Milliseconds(5);
};

// The simulator's format for a camera format: RAW (and RAW+JPEG) is DNG.
ImageFormat SimFormatOf(hardware::ImageFormat format);

class SimCamera final : public hardware::Camera {
 public:
  SimCamera(SimWorld& world, SimCameraOptions options);

  absl::StatusOr<hardware::CameraInfo> Info() override;
  absl::StatusOr<hardware::ExposureSettings> Configure(
      const hardware::ExposureSettings& settings) override;
  absl::StatusOr<hardware::ExposureSettings> Settings() override;
  absl::StatusOr<hardware::Frame> Capture() override;
  absl::StatusOr<int> PrepareCaptureGroup() override;
  // SimWorld::Preview at the current settings.
  absl::StatusOr<hardware::Frame> Preview() override;

 private:
  SimWorld& world_;
  const SimCameraOptions options_;
  std::mutex mutex_;
  hardware::ExposureSettings settings_;
};

class SimProjector final : public hardware::Projector {
 public:
  // FAILED_PRECONDITION when the world's scene has no projector.
  static absl::StatusOr<std::unique_ptr<SimProjector>> Create(SimWorld& world);

  cv::Size resolution() const override { return size_; }
  absl::Status Show(const cv::Mat& pattern) override;
  absl::Status Blank() override;
  // UNAVAILABLE while the scene's projector_faults.lost window holds.
  absl::Status Check() override;
  // The scene's projector.refresh_hz.
  absl::StatusOr<double> RefreshHz() override;

 private:
  SimProjector(SimWorld& world, cv::Size size) : world_(world), size_(size) {}
  SimWorld& world_;
  const cv::Size size_;
};

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_SIM_DEVICES_H_
