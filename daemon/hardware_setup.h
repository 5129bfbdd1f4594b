// SPDX-License-Identifier: GPL-3.0-or-later
//
// Builds the rig the configuration asks for: real drivers, or the simulated
// world with the real Zaber driver talking to the emulated controller (and,
// with --sim-camera ptpip, the real gphoto2 driver talking to the simulated
// PTP/IP camera), or
// (--camera-dump) that simulated world with the real camera driver
// configuring a replayed camera.
#ifndef HDRSTEREO_DAEMON_HARDWARE_SETUP_H_
#define HDRSTEREO_DAEMON_HARDWARE_SETUP_H_

#include <memory>

#include "absl/status/statusor.h"
#include "daemon/config.h"
#include "hardware/rig.h"
#include "hardware/sim/ptpip_camera.h"
#include "hardware/sim/sim_world.h"
#include "hardware/sim/stage_emulator.h"

namespace hdrstereo::daemon {

// Owns the rig and, in simulation, the world it lives in. Members are
// destroyed in reverse order: the rig's drivers before the emulator and the
// world they use.
struct Hardware {
  std::unique_ptr<sim::SimWorld> world;
  std::unique_ptr<sim::StageEmulator> emulator;
  std::unique_ptr<sim::PtpIpCamera> ptpip_camera;  // with --sim-camera ptpip
  std::unique_ptr<hardware::Rig> rig;
};

// A stage or projector that cannot be opened is left out of the rig (with
// the reason) so that the daemon still serves and reports it. The camera is
// always in the rig: one that is not there at the start is looked for with
// backoff, like one that dropped (hardware::ReconnectingCamera), unless the
// configuration can never match a camera (a --camera-model that libgphoto2
// or the --camera-dump replay does not know, a --camera-port that does not
// exist): that is an error, as is a bad scene in simulation (there is
// nothing to serve without it) and a dump that cannot be read.
absl::StatusOr<std::unique_ptr<Hardware>> SetUpHardware(const Config& config);

}  // namespace hdrstereo::daemon

#endif  // HDRSTEREO_DAEMON_HARDWARE_SETUP_H_
