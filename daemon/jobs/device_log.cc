// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/device_log.h"

#include <spdlog/spdlog.h>

#include <string>

#include "hardware/reconnecting_camera.h"
#include "hardware/stage.h"

namespace hdrstereo::jobs {

using store::Device;
using store::EventKind;

EventKind DeviceErrorKind(Device device, const absl::Status& status) {
  switch (device) {
    case Device::kCamera:
      if (hardware::IsCameraGone(status)) return EventKind::kCameraDisconnected;
      if (absl::IsDeadlineExceeded(status)) return EventKind::kCameraTimeout;
      if (absl::IsUnavailable(status)) return EventKind::kCameraBusy;
      return EventKind::kCameraError;
    case Device::kStage:
      if (hardware::IsStalled(status)) return EventKind::kStageStalled;
      if (absl::IsDeadlineExceeded(status)) return EventKind::kStageSilent;
      if (absl::IsDataLoss(status)) return EventKind::kStageGarbled;
      if (absl::IsAborted(status)) return EventKind::kStageFlag;
      return EventKind::kStageError;
    case Device::kProjector:
      return EventKind::kProjectorError;
  }
  return EventKind::kNone;
}

absl::Status MarkDeviceError(store::Device device, absl::Status status) {
  if (status.ok()) return status;
  const store::EventKind kind = DeviceErrorKind(device, status);
  return store::WithEventKind(std::move(status), kind);
}

bool IsTransientDeviceError(const absl::Status& status) {
  switch (store::EventKindOf(status)) {
    case EventKind::kCameraTimeout:
    case EventKind::kCameraBusy:
    case EventKind::kStageSilent:
    case EventKind::kStageGarbled:
    case EventKind::kStageStalled:
    case EventKind::kStageFlag:
      return true;
    case EventKind::kProjectorError:
      return absl::IsUnavailable(status) || absl::IsDeadlineExceeded(status);
    default:
      return false;
  }
}

DeviceLog::~DeviceLog() { Flush(); }

void DeviceLog::Wait(absl::Duration wait) {
  absl::SleepFor(wait);
  total_ += wait;
}

void DeviceLog::Add(Device device, bool sample, absl::Time start,
                    absl::Time end) {
  total_ += end - start;
  if (!sample) return;
  unrecorded_.push_back({.device = device,
                         .seconds = absl::ToDoubleSeconds(end - start),
                         .time_ms = absl::ToUnixMillis(end)});
  if (end - last_flush_ >= kFlushInterval) Flush();
}

void DeviceLog::Flush() {
  last_flush_ = absl::Now();
  if (absl::Status s = repository_.Record(job_id_, unrecorded_); !s.ok()) {
    spdlog::warn("job {}: cannot record the time of {} device call(s): {}",
                 job_id_, unrecorded_.size(), std::string(s.message()));
    return;
  }
  unrecorded_.clear();
}

}  // namespace hdrstereo::jobs
