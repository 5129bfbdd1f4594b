// SPDX-License-Identifier: GPL-3.0-or-later
//
// A real camera (DSLR, mirrorless) over libgphoto2.
//
//   Gphoto2Options options;           // first camera found, capture to RAM
//   options.model = "Canon EOS 5D Mark III";  // optional
//   absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
//       Gphoto2Camera::Open(options);
//   (*camera)->Configure({.exposure_s = 1.0 / 100, .iso = 100,
//                         .format = hardware::ImageFormat::kRaw});
//   // -> exposure_s = 1/100 if offered, else the nearest choice (e.g. 1/125)
//   absl::StatusOr<hardware::Frame> frame = (*camera)->Capture();
//
// Settings map onto the camera's widgets, whichever the camera has:
// exposure -> "shutterspeed" / "shutterspeed2" / "exposuretime" (the nearest
// timed choice in stops; bulb is never used), ISO -> "iso" / "isospeed",
// aperture -> "aperture" / "f-number" / "fnumber" (a choice, or a number for
// a range widget), format -> "imageformat" /
// "imagequality" (a camera without one, such as a generic PTP camera,
// delivers one format: Configure takes any format until a captured file
// shows which, and Capture() fails with FAILED_PRECONDITION on a file of
// another format than asked). Configure validates everything before it
// sets anything,
// then reads the settings back and fails if the camera did not take them
// (FAILED_PRECONDITION: typically the mode dial is not on M).
//
// Capture() runs gp_camera_capture, downloads the file (gp_camera_file_get)
// and deletes it from the camera (gp_camera_file_delete). With RAW+JPEG the
// camera announces the second file as an event; both are deleted and the RAW
// file is returned. A failed delete does not fail the capture; the file is
// remembered in undeleted_files().
//
// Live view: Preview() runs gp_camera_capture_preview, which puts the camera
// in live view (a DSLR raises its mirror) and leaves it there. A second
// preview answered "PTP Device Busy" (libgphoto2#66: the camera is still
// starting live view) is the busy retry below. Before the next Capture()
// the driver leaves live view by setting the camera's viewfinder toggle
// (kViewfinderWidgets: "viewfinder", "eosviewfinder") to 0: with the mirror
// still up a capture fails or is taken without autofocus (libgphoto2#247,
// gphoto2#121, libgphoto2#168). A camera without the toggle ends live view
// by itself.
//
// Retries: a call answered GP_ERROR_CAMERA_BUSY (-110, "I/O in progress") is
// retried up to `busy_retries` times, sleeping busy_backoff, 2x, 4x ... (at
// most busy_backoff_max) in between; then UNAVAILABLE. Other errors are not
// retried. So one call takes at most (busy_retries + 1) times its deadline
// plus the sleeps.
//
// Timeouts: every libgphoto2 call runs on this camera's own worker thread;
// the caller waits at most the call's deadline, then the call is asked to
// cancel (the GPContext cancel callback starts answering "cancel", which
// libgphoto2 checks between transfer chunks) and given `cancel_grace` to
// return; either way the caller gets DEADLINE_EXCEEDED. A call whose
// deadline passed before it began is skipped. A call that did not return
// within the grace cannot be killed: it keeps the worker thread until
// libgphoto2 returns (over USB usually when a transfer timeout fires;
// libgphoto2 gives no hard bound), and the camera is stuck: its error, and
// that of every call until the stuck one returns (UNAVAILABLE naming it,
// failing fast), are marked hardware::CameraStuckError, which
// ReconnectingCamera takes for a drop. Once the stuck call returns the
// camera is usable again. Destroying the camera while a call is stuck does
// not wait: the worker thread is detached and closes the camera
// (gp_camera_exit) if and when the call returns; WatchHandle() tells when.
//
// Thread-safe: calls from several threads are serialized.
#ifndef HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_CAMERA_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_CAMERA_H_

#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "hardware/camera.h"
#include "hardware/gphoto2/gphoto2_api.h"
#include "hardware/gphoto2/settings.h"

namespace hdrstereo::gphoto2 {

struct Gphoto2Options {
  // Which camera: both empty = the first one autodetected. A model alone
  // (matched case-insensitively against autodetect's names) or a port alone
  // ("usb:001,004") picks among the detected cameras. Both together open
  // that model on that port without autodetection, which is also how
  // libgphoto2's "Directory Browse" driver opens a folder as a camera:
  // model "Directory Browse", port "disk:/path/to/folder".
  std::string model;
  std::string port;
  // Applied at Open when the camera has a "capturetarget" widget (ignored
  // otherwise). Internal RAM needs no card and is faster.
  CaptureTarget capture_target = CaptureTarget::kInternalRam;
  // Deadline of each ordinary call (open, config, list, delete).
  absl::Duration call_timeout = absl::Seconds(10);
  // Deadline of a capture: this plus the current exposure time.
  absl::Duration capture_timeout = absl::Seconds(30);
  // Deadline of one file download.
  absl::Duration download_timeout = absl::Seconds(60);
  // Deadline of one live-view frame (the first also starts live view).
  absl::Duration preview_timeout = absl::Seconds(10);
  // How long a call that timed out is given to return once asked to
  // cancel before the camera counts as stuck (see above).
  absl::Duration cancel_grace = absl::Seconds(1);
  // Gphoto2Opener: how long after a stuck call timed out a new handle is
  // still not opened while libgphoto2 holds the old one.
  absl::Duration stuck_handle_wait = absl::Seconds(60);
  // How long PrepareCaptureGroup waits for each pending event.
  absl::Duration drain_event_wait = absl::Milliseconds(100);
  // How long to wait for the second file of a RAW+JPEG capture.
  absl::Duration second_file_timeout = absl::Seconds(5);
  // GP_ERROR_CAMERA_BUSY handling (see above).
  int busy_retries = 5;
  absl::Duration busy_backoff = absl::Milliseconds(100);
  absl::Duration busy_backoff_max = absl::Seconds(2);
  // Delete each captured file from the camera after downloading it.
  bool delete_after_download = true;
  // For a camera without an image format setting: the format it delivers,
  // when known (Configure then refuses any other with INVALID_ARGUMENT);
  // unset, the first captured file tells.
  std::optional<hardware::ImageFormat> fixed_format;
};

// What holds a camera's libgphoto2 handle (Gphoto2Camera::WatchHandle).
struct HandleUse {
  // The call stuck in libgphoto2 and when it timed out; "" and
  // InfiniteFuture when no call is stuck (the camera is still in use).
  std::string stuck_call;
  absl::Time stuck_since = absl::InfiniteFuture();
};

class Gphoto2Camera final : public hardware::Camera {
 public:
  // Opens a camera over the real libgphoto2. Errors: UNAVAILABLE "no camera
  // found" (autodetect listed none) or "no camera matching ..." (listing those
  // found), UNAVAILABLE "could not claim the USB device" (another process
  // holds it; the message says which one usually does and how to stop it),
  // NOT_FOUND for a model libgphoto2 does not know (checked before any
  // camera is looked for) or a port that does not exist, DEADLINE_EXCEEDED.
  // So NOT_FOUND is a configuration that no camera satisfies; the others may
  // pass once the camera is there.
  static absl::StatusOr<std::unique_ptr<Gphoto2Camera>> Open(
      const Gphoto2Options& options);
  // The same over any Gphoto2Api (tests pass a fake).
  static absl::StatusOr<std::unique_ptr<Gphoto2Camera>> OpenWithApi(
      const Gphoto2Options& options, std::unique_ptr<Gphoto2Api> api);

  // Makes a fresh Gphoto2Api: one per camera handle.
  using ApiFactory = std::function<std::unique_ptr<Gphoto2Api>()>;
  // Opens a camera that went away (USB reset, power saving, cable) again;
  // its port has usually changed, so options.port is ignored. With a
  // `serial`: autodetects, opens each detected camera of options.model (any
  // model when empty) on an api of its own and keeps the one whose
  // "serialnumber" widget is `serial` (the others are closed again);
  // UNAVAILABLE "no camera with serial number ..." naming those found.
  // A camera on a network port (IsNetworkPort) is opened again at that
  // port instead, and must have that serial number.
  // Without: the first camera of options.model, as Open. Every call has its
  // usual timeout. ReconnectingCamera (hardware/reconnecting_camera.h) calls
  // this with backoff.
  static absl::StatusOr<std::unique_ptr<Gphoto2Camera>> Reopen(
      const Gphoto2Options& options, const std::string& serial,
      const ApiFactory& new_api);

  ~Gphoto2Camera() override;
  Gphoto2Camera(const Gphoto2Camera&) = delete;
  Gphoto2Camera& operator=(const Gphoto2Camera&) = delete;

  // Model, serial ("serialnumber" widget), port, battery ("batterylevel"),
  // the shutter-speed range. Cameras without configuration (e.g. Directory
  // Browse) give model and port only.
  absl::StatusOr<hardware::CameraInfo> Info() override;
  absl::StatusOr<hardware::ExposureSettings> Configure(
      const hardware::ExposureSettings& settings) override;
  // exposure_s is 0 for bulb, iso 0 for auto, aperture_f 0 when unknown.
  absl::StatusOr<hardware::ExposureSettings> Settings() override;
  // Frame.format is the format of Frame.bytes (kRaw for the RAW file of a
  // RAW+JPEG capture); Frame.exposure_s the shutter speed last read or set
  // through this object (a change on the camera body shows after the next
  // Settings() or Configure()); camera_time the file's time on the camera.
  absl::StatusOr<hardware::Frame> Capture() override;
  // Sets `capture_target` again (cameras have been seen to switch it), then
  // waits for camera events up to `drain_event_wait` each, deleting every
  // announced file, until one wait times out (at most 64 events).
  absl::StatusOr<int> PrepareCaptureGroup() override;
  // A live-view frame (JPEG). DATA_LOSS when the camera sends no JPEG,
  // UNIMPLEMENTED for a camera without live view.
  absl::StatusOr<hardware::Frame> Preview() override;

  // The whole current configuration, flattened (e.g. for a status page).
  absl::StatusOr<std::vector<ConfigWidget>> Config();
  // gp_camera_get_summary text.
  absl::StatusOr<std::string> Summary();
  // Sets any widget by name to a value (a choice of radio/menu widgets must
  // be one of its choices: INVALID_ARGUMENT listing them otherwise).
  absl::Status SetConfigValue(const std::string& name,
                              const std::string& value);
  absl::Status SetCaptureTarget(CaptureTarget target);

  // Files on the camera (or in the Directory Browse folder).
  absl::StatusOr<std::vector<std::string>> ListFiles(const std::string& folder);
  // Downloads one file (format and extension from its name).
  absl::StatusOr<hardware::Frame> Download(const std::string& folder,
                                           const std::string& name);
  absl::Status DeleteFile(const std::string& folder, const std::string& name);

  // "folder/name" of captured files that could not be deleted.
  std::vector<std::string> undeleted_files() const;
  // What holds this camera's libgphoto2 handle, nullopt once it is closed.
  // Stays valid after the camera is destroyed, when only a stuck call can
  // hold the handle (until libgphoto2 returns). Thread-safe.
  using HandleWatch = std::function<std::optional<HandleUse>()>;
  HandleWatch WatchHandle() const;
  const std::string& model() const { return model_; }
  const std::string& port() const { return port_; }

 private:
  class Worker;

  Gphoto2Camera(const Gphoto2Options& options, std::unique_ptr<Gphoto2Api> api);

  // Runs fn on the worker with `timeout`, retrying GP_ERROR_CAMERA_BUSY;
  // maps a failure to a Status whose message starts with `what`.
  absl::Status Call(absl::string_view what, absl::Duration timeout,
                    std::function<int(Gphoto2Api&)> fn);
  // OK when the camera still answers a call that needs the connection
  // (the summary: over PTP it reads every property description), else that
  // call's error. After a plain GP_ERROR from a network camera it tells a
  // closed connection from a failed operation.
  absl::Status StillAnswers();
  absl::StatusOr<std::vector<ConfigWidget>> ConfigLocked();

  absl::StatusOr<hardware::ExposureSettings> SettingsLocked();
  absl::Status SetLocked(const std::string& name, const std::string& value);
  absl::StatusOr<hardware::Frame> DownloadLocked(const std::string& folder,
                                                 const std::string& name);
  absl::Status SetCaptureTargetLocked(CaptureTarget target);
  // Ends live view if a preview started it (see above).
  absl::Status LeaveLiveViewLocked();

  const Gphoto2Options options_;
  std::unique_ptr<Worker> worker_;
  std::string model_;
  std::string port_;
  mutable std::mutex mutex_;  // one operation at a time
  double exposure_s_ = 0;     // the shutter speed last read or set
  std::optional<hardware::ImageFormat> format_;  // the format last read
  // A camera without a format setting: the format Configure was last asked
  // for, and the format of the last file it delivered.
  std::optional<hardware::ImageFormat> fixed_format_asked_;
  std::optional<hardware::ImageFormat> delivered_format_;
  // Whether the camera has a capture target setting (only then does a
  // file's folder tell RAM from card), as the configuration last read.
  bool has_capture_target_ = false;
  std::vector<std::string> undeleted_files_;
  bool live_view_ = false;  // a preview may have started live view
};

// The status for a libgphoto2 result code: `what` failed because ... (for
// the classic failures, with what to do about it). Exposed for tests.
absl::Status Gphoto2Error(absl::string_view what, int code,
                          absl::string_view detail);

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_GPHOTO2_CAMERA_H_
