// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/event_kind.h"

#include <string>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"

namespace hdrstereo::store {
namespace {

constexpr struct {
  Device device;
  const char* name;
} kDeviceNames[] = {
    {Device::kCamera, "camera"},
    {Device::kStage, "stage"},
    {Device::kProjector, "projector"},
};

struct KindInfo {
  EventKind kind;
  const char* name;  // stored, and the label of verification failures
  EventFamily family;
  std::optional<Device> device;
  const char* label;  // a device error's label
};

constexpr EventFamily kVerification = EventFamily::kVerificationFailure;
constexpr EventFamily kDeviceError = EventFamily::kDeviceError;

constexpr KindInfo kKinds[] = {
    {EventKind::kNone, "", EventFamily::kNone, std::nullopt, ""},
    {EventKind::kPreviousFile, "previous_file", kVerification, std::nullopt,
     "previous_file"},
    {EventKind::kWrongExposure, "wrong_exposure", kVerification, std::nullopt,
     "wrong_exposure"},
    {EventKind::kWrongIso, "wrong_iso", kVerification, std::nullopt,
     "wrong_iso"},
    {EventKind::kWrongAperture, "wrong_aperture", kVerification, std::nullopt,
     "wrong_aperture"},
    {EventKind::kCardTarget, "card_target", kVerification, std::nullopt,
     "card_target"},
    {EventKind::kCorrupt, "corrupt", kVerification, std::nullopt, "corrupt"},
    {EventKind::kCameraTimeout, "camera_timeout", kDeviceError, Device::kCamera,
     "timeout"},
    {EventKind::kCameraBusy, "camera_busy", kDeviceError, Device::kCamera,
     "busy"},
    {EventKind::kCameraDisconnected, "camera_disconnected", kDeviceError,
     Device::kCamera, "disconnected"},
    {EventKind::kCameraError, "camera_error", kDeviceError, Device::kCamera,
     "error"},
    {EventKind::kStageSilent, "stage_silent", kDeviceError, Device::kStage,
     "silent"},
    {EventKind::kStageGarbled, "stage_garbled", kDeviceError, Device::kStage,
     "garbled"},
    {EventKind::kStageStalled, "stage_stalled", kDeviceError, Device::kStage,
     "stalled"},
    {EventKind::kStageFlag, "stage_flag", kDeviceError, Device::kStage, "flag"},
    {EventKind::kStageError, "stage_error", kDeviceError, Device::kStage,
     "error"},
    {EventKind::kProjectorError, "projector_error", kDeviceError,
     Device::kProjector, "error"},
    {EventKind::kStepComputed, "step_computed", EventFamily::kStepComputed,
     std::nullopt, "step_computed"},
};

const KindInfo& InfoOf(EventKind kind) {
  for (const KindInfo& info : kKinds) {
    if (info.kind == kind) return info;
  }
  return kKinds[0];
}

// The status payload that carries a kind (its name).
constexpr char kPayloadUrl[] = "type.hdrstereo.org/hdrstereo.EventKind";

}  // namespace

const char* DeviceName(Device device) {
  for (const auto& entry : kDeviceNames) {
    if (entry.device == device) return entry.name;
  }
  return "unknown";
}

absl::StatusOr<Device> ParseDevice(absl::string_view name) {
  for (const auto& entry : kDeviceNames) {
    if (name == entry.name) return entry.device;
  }
  return absl::DataLossError(absl::StrCat("unknown device \"", name, "\""));
}

const char* EventKindName(EventKind kind) { return InfoOf(kind).name; }

absl::StatusOr<EventKind> ParseEventKind(absl::string_view name) {
  for (const KindInfo& info : kKinds) {
    if (name == info.name) return info.kind;
  }
  return absl::DataLossError(
      absl::StrCat("unknown job event kind \"", name, "\""));
}

EventFamily FamilyOf(EventKind kind) { return InfoOf(kind).family; }

std::vector<EventKind> KindsOf(EventFamily family) {
  std::vector<EventKind> kinds;
  for (const KindInfo& info : kKinds) {
    if (info.family == family) kinds.push_back(info.kind);
  }
  return kinds;
}

std::optional<Device> DeviceOf(EventKind kind) { return InfoOf(kind).device; }

const char* LabelOf(EventKind kind) { return InfoOf(kind).label; }

absl::Status WithEventKind(absl::Status status, EventKind kind) {
  if (!status.ok()) {
    status.SetPayload(kPayloadUrl, absl::Cord(EventKindName(kind)));
  }
  return status;
}

EventKind EventKindOf(const absl::Status& status) {
  const auto payload = status.GetPayload(kPayloadUrl);
  if (!payload.has_value()) return EventKind::kNone;
  absl::StatusOr<EventKind> kind = ParseEventKind(std::string(*payload));
  return kind.ok() ? *kind : EventKind::kNone;
}

}  // namespace hdrstereo::store
