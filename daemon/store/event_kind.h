// SPDX-License-Identifier: GPL-3.0-or-later
//
// What a job event counts for: a stable kind recorded with the event
// (job_events.kind), so that the metrics count frame verification
// failures, device errors and processing steps by kind rather than by
// their text. This file is the one owner of the kinds and of their names;
// the names are what the database stores and what the metrics' labels say,
// so a released name is never changed (append new kinds instead).
#ifndef HDRSTEREO_DAEMON_STORE_EVENT_KIND_H_
#define HDRSTEREO_DAEMON_STORE_EVENT_KIND_H_

#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::store {

// The devices of the rig, as device errors and device time name them.
enum class Device { kCamera, kStage, kProjector };
inline constexpr Device kAllDevices[] = {Device::kCamera, Device::kStage,
                                         Device::kProjector};
const char* DeviceName(Device device);  // as stored: "camera", ...
absl::StatusOr<Device> ParseDevice(absl::string_view name);

enum class EventKind {
  kNone,  // an event that is not counted (stored as '')
  // A frame rejected by its check against the camera (daemon/jobs/
  // frame_check.h), or one that arrived corrupt.
  kPreviousFile,
  kWrongExposure,
  kWrongIso,
  kWrongAperture,
  kCardTarget,
  kCorrupt,
  // A device call of a capture job that failed.
  kCameraTimeout,       // DEADLINE_EXCEEDED
  kCameraBusy,          // UNAVAILABLE: busy after the driver's retries
  kCameraDisconnected,  // the camera dropped (ReconnectingCamera)
  kCameraError,         // anything else
  kStageSilent,         // no reply within the driver's tries
  kStageGarbled,        // replies that do not parse
  kStageStalled,        // a move that did not finish in time
  kStageFlag,           // a fault flag (FS, ...) aborted the command
  kStageError,          // anything else
  kProjectorError,
  // A processing step was computed: the event names the step (subject) and
  // how long it took (seconds).
  kStepComputed,
};

enum class EventFamily {
  kNone,
  kVerificationFailure,
  kDeviceError,
  kStepComputed,
};

const char* EventKindName(EventKind kind);  // as stored; "" for kNone
// DATA_LOSS for a name this binary does not know.
absl::StatusOr<EventKind> ParseEventKind(absl::string_view name);
EventFamily FamilyOf(EventKind kind);
// The kinds of `family`, in declaration order.
std::vector<EventKind> KindsOf(EventFamily family);
// For a device error: its device (nullopt for other kinds), and the
// error's label without the device ("timeout"); for other kinds the label
// is the name.
std::optional<Device> DeviceOf(EventKind kind);
const char* LabelOf(EventKind kind);

// Marks an error with the event kind its job's final event is to record
// (e.g. the device error that failed a capture); OK stays OK.
absl::Status WithEventKind(absl::Status status, EventKind kind);
// The kind `status` was marked with; kNone when none.
EventKind EventKindOf(const absl::Status& status);

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_EVENT_KIND_H_
