// SPDX-License-Identifier: GPL-3.0-or-later
//
// The rig: one camera on a linear stage plus a projector, with the rig's
// configuration. A device that could not be opened is absent (nullptr) and
// the reason is kept, so the daemon can serve and report it.
#ifndef HDRSTEREO_HARDWARE_RIG_H_
#define HDRSTEREO_HARDWARE_RIG_H_

#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>

#include "absl/status/status.h"
#include "hardware/camera.h"
#include "hardware/projector.h"
#include "hardware/stage.h"

namespace hdrstereo::hardware {

// Which devices the rig drives: the simulated world or the lab's.
enum class HardwareMode { kSim, kReal };
// "sim", "real" (as in the daemon's configuration).
inline const char* HardwareModeName(HardwareMode mode) {
  return mode == HardwareMode::kSim ? "sim" : "real";
}

struct RigConfig {
  HardwareMode mode = HardwareMode::kSim;
  // The stage position of the left view; views step right from here.
  double home_position_mm = 0;
  double max_baseline_mm = 150;
};

// A device or why it is missing.
template <typename Device>
struct Slot {
  std::unique_ptr<Device> device;
  absl::Status error;  // set when device is null
};

class Rig {
 public:
  Rig(RigConfig config, Slot<Camera> camera, Slot<Stage> stage,
      Slot<Projector> projector)
      : config_(std::move(config)),
        camera_(std::move(camera)),
        stage_(std::move(stage)),
        projector_(std::move(projector)) {}

  const RigConfig& config() const { return config_; }
  // nullptr when the device is missing; *_error() says why.
  Camera* camera() const { return camera_.device.get(); }
  Stage* stage() const { return stage_.device.get(); }
  Projector* projector() const { return projector_.device.get(); }
  const absl::Status& camera_error() const { return camera_.error; }
  const absl::Status& stage_error() const { return stage_.error; }
  const absl::Status& projector_error() const { return projector_.error; }

  // The hardware is exclusive: a capture holds this for its whole run, and
  // direct control (Hardware RPCs) only tries to take it.
  std::mutex& lane() { return lane_; }

 private:
  const RigConfig config_;
  Slot<Camera> camera_;
  Slot<Stage> stage_;
  Slot<Projector> projector_;
  std::mutex lane_;
};

}  // namespace hdrstereo::hardware

#endif  // HDRSTEREO_HARDWARE_RIG_H_
