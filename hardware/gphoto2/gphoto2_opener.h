// SPDX-License-Identifier: GPL-3.0-or-later
//
// Opens one gphoto2 camera for as long as the daemon runs: first as
// configured, then, each time it dropped, the same body again. This is what
// ReconnectingCamera (hardware/reconnecting_camera.h) calls to open a real
// camera, or a replayed one (any Gphoto2Api).
//
//   Gphoto2Opener opener(options, [] { return NewLibgphoto2Api(); });
//   absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera = opener.Open();
//   ... the camera drops and is let go ...
//   camera = opener.Open();  // by the serial number it had, on a new port
//
// Until a camera was opened, Open() is Gphoto2Camera::OpenWithApi with the
// options (model and port as configured). Once one was, it is
// Gphoto2Camera::Reopen by that camera's serial number (the port changes
// after a USB reset), or by its model when it has none.
//
// No second libgphoto2 handle is opened on the camera while the previous
// one is still held: by a call of the dropped camera that timed out and
// has not returned from libgphoto2 (the camera was stuck), or by a call
// still in progress. Such an attempt fails with UNAVAILABLE saying what
// holds the handle, until the call returns and the old handle is closed,
// or until options.stuck_handle_wait has passed since the call timed out:
// then the old handle is abandoned to its thread (closed if and when
// libgphoto2 returns) and a new one is opened, so that a camera whose old
// handle libgphoto2 never lets go of is reopened all the same. A camera on
// a network port (IsNetworkPort) is not waited for: its stuck call holds
// only a TCP connection. A PTP/IP camera serves one client, so it should
// drop the old connection when the new one arrives, which ends the stuck
// call (the simulated camera does; not checked on real bodies: one that
// kept both would leave the stuck call's thread and sockets behind).
//
// Not thread-safe: one Open() at a time (ReconnectingCamera calls it from
// its reconnect thread only, after the first open).
#ifndef HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_OPENER_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_OPENER_H_

#include <functional>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "hardware/camera.h"
#include "hardware/gphoto2/gphoto2_camera.h"

namespace hdrstereo::gphoto2 {

class Gphoto2Opener {
 public:
  Gphoto2Opener(Gphoto2Options options, Gphoto2Camera::ApiFactory new_api);

  // Errors: those of OpenWithApi (first) or Reopen (after that), or
  // UNAVAILABLE while the previous handle is held (above).
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> Open();

  // After the first open: the camera's model, and the serial number that
  // reopens look for ("" when it has none: then they look for the model).
  const std::string& model() const { return options_.model; }
  const std::string& serial() const { return serial_; }

 private:
  // OK once no handle of the camera opened last is held, or it is
  // abandoned.
  absl::Status PreviousHandleLetGo();

  Gphoto2Options options_;
  const Gphoto2Camera::ApiFactory new_api_;
  bool opened_once_ = false;
  std::string serial_;
  Gphoto2Camera::HandleWatch previous_;  // of the camera opened last
};

// `opener` as ReconnectingCamera's CameraOpener: each call is Open().
std::function<absl::StatusOr<std::unique_ptr<hardware::Camera>>()>
CameraOpenerOf(std::shared_ptr<Gphoto2Opener> opener);

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_OPENER_H_
