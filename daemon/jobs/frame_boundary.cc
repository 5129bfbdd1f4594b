// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/frame_boundary.h"

#include "absl/strings/cord.h"
#include "absl/strings/str_join.h"
#include "hardware/reconnecting_camera.h"

namespace hdrstereo::jobs {

// `status` with `step` (what the call was doing) before its message; the
// code and payloads (the device error kind, a stalled move) are kept.
absl::Status InStep(absl::string_view step, const absl::Status& status) {
  if (status.ok()) return status;
  absl::Status in_step(status.code(),
                       absl::StrCat(step, ": ", status.message()));
  status.ForEachPayload([&](absl::string_view url, const absl::Cord& payload) {
    in_step.SetPayload(url, payload);
  });
  return in_step;
}

absl::Status Attempts::Retry(const absl::Status& failed) {
  const store::EventKind kind = store::EventKindOf(failed);
  failures_.emplace_back(failed.message());
  const int tried = static_cast<int>(failures_.size());
  const bool transient = IsTransientDeviceError(failed);
  if (transient && tried < kMaxAttemptsPerFrame) {
    context_.Warn(absl::StrCat(what_, ": ", failed.message(), "; ",
                               store::DeviceOf(kind) == store::Device::kStage
                                   ? "the stage is homed again and "
                                   : "",
                               again_, " (attempt ", tried + 1, " of at most ",
                               kMaxAttemptsPerFrame, ")"),
                  store::EventTag(kind));
    return absl::OkStatus();
  }
  std::string message = absl::StrCat(what_, ": ", failures_.front());
  if (tried > 1) {
    message = absl::StrCat(what_, " failed ", tried, " times:");
    for (int i = 0; i < tried; ++i) {
      absl::StrAppend(&message, i > 0 ? ";" : "", " ", i + 1, ") ",
                      failures_[i]);
    }
  }
  if (!transient) {
    absl::StrAppend(&message,
                    "; not tried again: this fault does not pass by itself");
  }
  return store::WithEventKind(
      absl::Status(failed.code(), absl::StrCat(message, "; ", outcome_)), kind);
}

// Why the next frame cannot be taken now ("" when it can): the suspenders,
// asked at every frame boundary. `projector`: the one the plan needs
// (structured light), else nullptr. The queries are device calls, timed in
// `devices` like the others.
std::string BlockingCondition(const CaptureConditions& conditions,
                              hardware::Camera& camera, hardware::Stage& stage,
                              hardware::Projector* projector,
                              const DiskNeed& disk_need, DeviceLog& devices) {
  // A camera that dropped is being reopened (ReconnectingCamera): wait.
  if (const hardware::ConnectionState link = camera.Connection();
      !link.connected) {
    return absl::StrCat("camera disconnected, ",
                        hardware::DescribeConnection(link));
  }
  // Info() reads the camera's whole configuration on gphoto2 (slow), so it
  // is asked only when the battery is watched.
  if (conditions.min_battery_percent > 0) {
    absl::StatusOr<hardware::CameraInfo> info =
        devices.Time(store::Device::kCamera, [&] { return camera.Info(); });
    if (!info.ok()) {
      return absl::StrCat("the camera does not answer: ",
                          info.status().message());
    }
    if (info->battery_percent >= 0 &&
        info->battery_percent < conditions.min_battery_percent) {
      return absl::StrCat("the camera battery is at ", info->battery_percent,
                          "%, below --min-battery-percent ",
                          conditions.min_battery_percent, "%");
    }
  }
  absl::StatusOr<hardware::StageState> state =
      devices.Time(store::Device::kStage, [&] { return stage.State(); });
  if (!state.ok()) {
    return absl::StrCat("the stage does not read back: ",
                        state.status().message());
  }
  std::vector<std::string> warnings;
  for (const std::string& flag : state->warning_flags) {
    if (flag != "WR") warnings.push_back(flag);  // WR: not homed, re-homed
  }
  if (!warnings.empty()) {
    return absl::StrCat("the stage reports warning flags ",
                        absl::StrJoin(warnings, " "));
  }
  if (projector != nullptr) {
    if (absl::Status s = devices.Time(store::Device::kProjector,
                                      [&] { return projector->Check(); });
        !s.ok()) {
      return absl::StrCat("the projector is lost: ", s.message());
    }
  }
  if (conditions.disk != nullptr) {
    if (absl::Status s = conditions.disk->CheckRoomForRest(
            disk_need.frames, disk_need.bytes_per_frame);
        !s.ok()) {
      return disk_need.write_failure.empty()
                 ? std::string(s.message())
                 : absl::StrCat(disk_need.write_failure, "; ", s.message());
    }
  }
  return "";
}

bool CameraDropped(hardware::Camera& camera, int64_t drops_before) {
  const hardware::ConnectionState link = camera.Connection();
  return link.drops != drops_before || !link.connected;
}

absl::Status OnCameraDrop(JobContext& context, absl::string_view what,
                          absl::string_view again, const absl::Status& failed,
                          int* drops) {
  if (*drops >= kMaxDropsPerFrame) {
    return store::WithEventKind(
        absl::Status(
            failed.code(),
            absl::StrCat(what, ": the camera dropped ", *drops + 1,
                         " times while taking it; last: ", failed.message())),
        store::EventKind::kCameraDisconnected);
  }
  context.Warn(absl::StrCat(what, ": the camera dropped (", failed.message(),
                            "); ", again, " once it is back"),
               store::EventTag(store::EventKind::kCameraDisconnected));
  ++*drops;
  return absl::OkStatus();
}

}  // namespace hdrstereo::jobs
