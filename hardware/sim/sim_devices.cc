// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/sim_devices.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::sim {
namespace {

constexpr double kMinExposureS = 1.0 / 8000;
constexpr double kMaxExposureS = 30;

struct Delivered {
  hardware::ImageFormat format;
  const char* extension;
};

Delivered Describe(ImageFormat format) {
  switch (format) {
    case ImageFormat::kJpeg:
      return {hardware::ImageFormat::kJpeg, "jpg"};
    case ImageFormat::kDng:
      return {hardware::ImageFormat::kRaw, "dng"};
    case ImageFormat::kTiff16:
      return {hardware::ImageFormat::kTiff16, "tiff"};
    case ImageFormat::kPng:
      return {hardware::ImageFormat::kPng8, "png"};
  }
  return {hardware::ImageFormat::kPng8, "png"};
}

}  // namespace

ImageFormat SimFormatOf(hardware::ImageFormat format) {
  switch (format) {
    case hardware::ImageFormat::kJpeg:
      return ImageFormat::kJpeg;
    case hardware::ImageFormat::kRaw:
    case hardware::ImageFormat::kRawAndJpeg:
      return ImageFormat::kDng;
    case hardware::ImageFormat::kTiff16:
      return ImageFormat::kTiff16;
    case hardware::ImageFormat::kPng8:
      return ImageFormat::kPng;
  }
  return ImageFormat::kPng;
}

SimCamera::SimCamera(SimWorld& world, SimCameraOptions options)
    : world_(world), options_(options) {
  settings_.exposure_s = 1.0 / 125;
  settings_.iso = 100;
  settings_.aperture_f = 8;
  settings_.format = options.format;
}

absl::StatusOr<hardware::CameraInfo> SimCamera::Info() {
  return hardware::CameraInfo{
      .model = absl::StrCat("hdrstereo simulated camera (", world_.scene().name,
                            ")"),
      .serial = absl::StrCat("sim-", world_.scene().seed),
      .port = "sim",
      .battery_percent = world_.ReadBattery(),
      .min_exposure_s = kMinExposureS,
      .max_exposure_s = kMaxExposureS,
      .shutter_speeds_s = {},  // any exposure in the range
  };
}

absl::StatusOr<hardware::ExposureSettings> SimCamera::Configure(
    const hardware::ExposureSettings& settings) {
  if (!(settings.exposure_s >= kMinExposureS &&
        settings.exposure_s <= kMaxExposureS)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "exposure %g s is outside the simulated camera's [%g, %g] s",
        settings.exposure_s, kMinExposureS, kMaxExposureS));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  settings_.exposure_s = settings.exposure_s;
  if (settings.iso > 0) settings_.iso = settings.iso;
  if (settings.aperture_f > 0) settings_.aperture_f = settings.aperture_f;
  if (settings.format.has_value()) settings_.format = settings.format;
  return settings_;
}

absl::StatusOr<hardware::ExposureSettings> SimCamera::Settings() {
  std::lock_guard<std::mutex> lock(mutex_);
  return settings_;
}

absl::StatusOr<hardware::Frame> SimCamera::Capture() {
  hardware::ExposureSettings settings;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    settings = settings_;
  }
  const ImageFormat format = SimFormatOf(*settings.format);
  absl::Duration backoff = options_.busy_backoff;
  for (int attempt = 0;; ++attempt) {
    absl::StatusOr<SimCapture> capture =
        world_.Capture({.exposure_s = settings.exposure_s,
                        .iso = double(settings.iso),
                        .aperture_f = settings.aperture_f},
                       format);
    if (capture.ok()) {
      const Delivered delivered = Describe(capture->format);
      return hardware::Frame{.bytes = std::move(capture->bytes),
                             .format = delivered.format,
                             .extension = delivered.extension,
                             .exposure_s = settings.exposure_s,  // as set
                             .width_px = capture->image.cols,
                             .height_px = capture->image.rows,
                             .camera_time = capture->camera_time,
                             .camera_file_name = capture->file_name,
                             .stored_to = capture->on_card
                                              ? hardware::StoredTo::kCard
                                              : hardware::StoredTo::kRam};
    }
    // Only "busy" is transient; everything else is the caller's to handle.
    if (!absl::IsUnavailable(capture.status()) ||
        capture.status().message().find("busy") == absl::string_view::npos ||
        attempt >= options_.busy_retries) {
      return capture.status();
    }
    absl::SleepFor(backoff);
    backoff *= 2;
  }
}

absl::StatusOr<int> SimCamera::PrepareCaptureGroup() {
  return world_.PrepareCaptureGroup();
}

absl::StatusOr<hardware::Frame> SimCamera::Preview() {
  hardware::ExposureSettings settings;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    settings = settings_;
  }
  ASSIGN_OR_RETURN(SimCapture preview,
                   world_.Preview({.exposure_s = settings.exposure_s,
                                   .iso = double(settings.iso),
                                   .aperture_f = settings.aperture_f}));
  hardware::Frame frame;
  frame.bytes = std::move(preview.bytes);
  frame.format = hardware::ImageFormat::kJpeg;
  frame.extension = "jpg";
  frame.exposure_s = settings.exposure_s;
  frame.width_px = preview.image.cols;
  frame.height_px = preview.image.rows;
  return frame;
}

absl::StatusOr<std::unique_ptr<SimProjector>> SimProjector::Create(
    SimWorld& world) {
  const ProjectorModel& model = world.scene().projector;
  if (!model.present) {
    return absl::FailedPreconditionError(absl::StrCat(
        "the simulated scene \"", world.scene().name, "\" has no projector"));
  }
  return std::unique_ptr<SimProjector>(
      new SimProjector(world, cv::Size(model.width, model.height)));
}

absl::Status SimProjector::Show(const cv::Mat& pattern) {
  RETURN_IF_ERROR(hardware::ValidatePattern(pattern, size_));
  RETURN_IF_ERROR(world_.ProjectorCall(/*shows_pattern=*/true));
  RETURN_IF_ERROR(world_.SetProjectorPattern(pattern));
  world_.SleepModelled(world_.timing().projector_settle_s);
  return absl::OkStatus();
}

absl::Status SimProjector::Blank() {
  RETURN_IF_ERROR(world_.ProjectorCall(/*shows_pattern=*/true));
  world_.BlankProjector();
  world_.SleepModelled(world_.timing().projector_settle_s);
  return absl::OkStatus();
}

absl::Status SimProjector::Check() {
  return world_.ProjectorCall(/*shows_pattern=*/false);
}

absl::StatusOr<double> SimProjector::RefreshHz() {
  return world_.scene().projector.refresh_hz;
}

}  // namespace hdrstereo::sim
