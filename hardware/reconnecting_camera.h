// SPDX-License-Identifier: GPL-3.0-or-later
//
// A camera that comes back: a decorator over any hardware::Camera that
// notices when the camera has gone (USB reset, power saving, a pulled cable)
// and reopens it in the background with exponential backoff, without a
// restart of the daemon. The reconnect loop lives here, once, for every
// driver; a driver only says how to open its camera again (CameraOpener:
// gphoto2 autodetects the camera by serial number, else model; the
// simulator asks its world).
//
//   ReconnectingCamera camera(std::move(opened), [] { return Reopen(); },
//                             ReconnectOptions{});
//   camera.Capture();     // UNAVAILABLE "... disconnected ..." -> dropped
//   camera.Connection();  // {connected = false, attempt = 1, drops = 1}
//   ... 0.5 s later the first reopen; 1 s after a failed one the next ...
//   camera.Connection();  // {connected = true, drops = 1}
//
// A call whose error says the camera is gone (IsCameraGone: disconnected,
// or stuck in a call that timed out) drops the camera: the call's own error
// is returned, the camera object is let go, and the reconnect thread opens
// a new one, waiting BackoffBefore(attempt) before each attempt. A camera
// that could not be opened in the first place starts away, as if it had
// dropped (no drop is counted), and is opened the same way. Every call made
// while the camera is away fails at once with UNAVAILABLE "camera disconnected;
// reconnecting (attempt N): <last error>" and does not count as another
// drop. Each reopen is the opener's own calls with their own timeouts; the
// decorator adds none and never retries a call itself: what to do with a
// call that failed (retake the frame, say) is the caller's decision, made
// by comparing Connection().drops before and after.
//
// Settings are not carried over: a reopened camera has the settings it
// comes back with, so callers configure it again (capture jobs do).
//
// Thread-safe. Connection() never waits for a camera call.
#ifndef HDRSTEREO_HARDWARE_RECONNECTING_CAMERA_H_
#define HDRSTEREO_HARDWARE_RECONNECTING_CAMERA_H_

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "hardware/camera.h"

namespace hdrstereo::hardware {

// The schedule of reopen attempts after a drop.
struct ReconnectOptions {
  // The wait before the first attempt (a device that re-enumerates after a
  // USB reset needs a moment), doubling (`multiplier`) after each failed
  // one up to `max_backoff`.
  absl::Duration initial_backoff = absl::Milliseconds(500);
  double multiplier = 2.0;
  absl::Duration max_backoff = absl::Seconds(30);
  // Called without locks held after every change: a drop (on the thread
  // whose call saw it), a failed attempt and the reconnect (on the
  // reconnect thread). May be empty.
  std::function<void(const ConnectionState&)> on_change;
};

// The wait before reopen attempt `attempt` (1-based): initial_backoff *
// multiplier^(attempt - 1), at most max_backoff; initial_backoff for
// attempt < 1.
absl::Duration BackoffBefore(const ReconnectOptions& options, int attempt);

// Whether a camera call's error says the camera has gone away rather than
// refused or failed one call: UNAVAILABLE, FAILED_PRECONDITION or ABORTED
// with "disconnected" in the message (gphoto2: "I/O error talking to the
// camera (disconnected?)", the whole GP_ERROR_IO range, and "not on the USB
// bus (disconnected: ...)", GP_ERROR_IO_USB_FIND; the simulator:
// "camera disconnected during transfer", "camera disconnected
// (simulated)"), or any error marked CameraStuckError (hardware/camera.h:
// the connection is held by a call that timed out and has not returned).
// "Busy", timeouts that the driver got back from and bad settings are not.
bool IsCameraGone(const absl::Status& status);

// "connected", or "reconnecting (attempt 3): <last error>".
std::string DescribeConnection(const ConnectionState& state);

// Opens the camera again (a new object; the old one is gone).
using CameraOpener = std::function<absl::StatusOr<std::unique_ptr<Camera>>()>;

class ReconnectingCamera final : public Camera {
 public:
  // `opened`: the camera as first opened, or why it could not be opened
  // (then it starts away: not connected, attempt 1, that error, no drop).
  // `reopen` is called from the reconnect thread only.
  ReconnectingCamera(absl::StatusOr<std::unique_ptr<Camera>> opened,
                     CameraOpener reopen, ReconnectOptions options = {});
  // Stops the reconnect thread (waits for an attempt in progress).
  ~ReconnectingCamera() override;
  ReconnectingCamera(const ReconnectingCamera&) = delete;
  ReconnectingCamera& operator=(const ReconnectingCamera&) = delete;

  absl::StatusOr<CameraInfo> Info() override;
  absl::StatusOr<ExposureSettings> Configure(
      const ExposureSettings& settings) override;
  absl::StatusOr<ExposureSettings> Settings() override;
  absl::StatusOr<Frame> Capture() override;
  absl::StatusOr<int> PrepareCaptureGroup() override;
  absl::StatusOr<Frame> Preview() override;
  ConnectionState Connection() const override;

 private:
  // The camera to call, or the error to answer while it is away.
  absl::StatusOr<std::shared_ptr<Camera>> Current() const;
  // After a failed call on `used`: drops it if `status` says it is gone.
  void Observe(const std::shared_ptr<Camera>& used, const absl::Status& status);
  template <typename T, typename Call>
  absl::StatusOr<T> Forward(Call call);
  void Loop();
  void Changed(const ConnectionState& state) const;

  const CameraOpener reopen_;
  const ReconnectOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::shared_ptr<Camera> camera_;  // null while away
  ConnectionState state_;
  bool stop_ = false;
  std::thread thread_;  // last: started when the rest is ready
};

}  // namespace hdrstereo::hardware

#endif  // HDRSTEREO_HARDWARE_RECONNECTING_CAMERA_H_
