// SPDX-License-Identifier: GPL-3.0-or-later
//
// A motorised linear stage carrying the camera along the baseline.
// Implementation: zaber/ (Zaber ASCII protocol over a serial port); in
// simulation the same driver talks to an emulated controller on a pty.
#ifndef HDRSTEREO_HARDWARE_STAGE_H_
#define HDRSTEREO_HARDWARE_STAGE_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/cord.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::hardware {

struct StageState {
  double position_mm = 0;
  bool homed = false;
  bool busy = false;
  // e.g. "WR" (not homed), "FZ" (peripheral inactive)
  std::vector<std::string> warning_flags;
};

// Moves block until the stage is idle again or a timeout derived from the
// distance and speed passes (DEADLINE_EXCEEDED, after a Stop). Targets outside
// [0, travel_mm] are INVALID_ARGUMENT and nothing moves.
class Stage {
 public:
  virtual ~Stage() = default;

  virtual absl::Status Home() = 0;
  virtual absl::Status MoveTo(double position_mm) = 0;
  virtual absl::StatusOr<StageState> State() = 0;
  virtual absl::Status Stop() = 0;
  virtual double travel_mm() const = 0;
};

// A move that was accepted but did not finish in time (the stage stalled)
// is DEADLINE_EXCEEDED like a controller that does not answer at all;
// drivers make it with StalledError so that callers can tell the two apart.
inline constexpr char kStalledPayloadUrl[] =
    "type.hdrstereo.org/hdrstereo.hardware.StageStalled";
inline absl::Status StalledError(absl::string_view message) {
  absl::Status status = absl::DeadlineExceededError(message);
  status.SetPayload(kStalledPayloadUrl, absl::Cord());
  return status;
}
inline bool IsStalled(const absl::Status& status) {
  return absl::IsDeadlineExceeded(status) &&
         status.GetPayload(kStalledPayloadUrl).has_value();
}

}  // namespace hdrstereo::hardware

#endif  // HDRSTEREO_HARDWARE_STAGE_H_
