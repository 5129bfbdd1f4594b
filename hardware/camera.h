// SPDX-License-Identifier: GPL-3.0-or-later
//
// A still camera: configure an exposure, capture one frame, get its bytes.
// Implementations: gphoto2/ (a real DSLR), sim/ (the simulated world).
#ifndef HDRSTEREO_HARDWARE_CAMERA_H_
#define HDRSTEREO_HARDWARE_CAMERA_H_

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/cord.h"
#include "absl/time/time.h"

namespace hdrstereo::hardware {

enum class ImageFormat {
  kJpeg,
  kRaw,         // camera RAW (CR2, NEF, DNG, ...)
  kRawAndJpeg,  // both; Capture() returns the RAW file
  kTiff16,      // 16-bit TIFF (simulated camera)
  kPng8,        // 8-bit PNG (simulated camera)
};

// Lowercase name, as in frame rows and file names.
inline const char* ImageFormatName(ImageFormat format) {
  switch (format) {
    case ImageFormat::kJpeg:
      return "jpeg";
    case ImageFormat::kRaw:
      return "raw";
    case ImageFormat::kRawAndJpeg:
      return "raw+jpeg";
    case ImageFormat::kTiff16:
      return "tiff16";
    case ImageFormat::kPng8:
      return "png8";
  }
  return "unknown";
}

// The format of an ImageFormatName; nullopt for any other text.
inline std::optional<ImageFormat> ParseImageFormat(std::string_view name) {
  for (ImageFormat f :
       {ImageFormat::kJpeg, ImageFormat::kRaw, ImageFormat::kRawAndJpeg,
        ImageFormat::kTiff16, ImageFormat::kPng8}) {
    if (name == ImageFormatName(f)) return f;
  }
  return std::nullopt;
}

struct ExposureSettings {
  double exposure_s = 0;              // > 0
  int iso = 0;                        // 0 = leave as is
  double aperture_f = 0;              // f-number; 0 = leave as is
  std::optional<ImageFormat> format;  // nullopt = leave as is
};

struct CameraInfo {
  std::string model;
  std::string serial;
  std::string port;
  int battery_percent = -1;  // -1 when unknown
  double min_exposure_s = 0;
  double max_exposure_s = 0;
  // The timed exposures the camera offers (gphoto2's `shutterspeed`
  // choices), ascending; empty when it takes any exposure in [min, max]
  // (the simulator).
  std::vector<double> shutter_speeds_s;
};

// Where the camera put a file before it was downloaded.
enum class StoredTo {
  kUnknown,
  kRam,   // the camera's internal RAM: what captures ask for
  kCard,  // the memory card: the capture target changed behind our back
};

// One captured image as the camera delivered it (encoded file bytes).
struct Frame {
  std::string bytes;
  ImageFormat format = ImageFormat::kJpeg;
  std::string extension;  // file name extension without the dot, e.g. "cr2"
  double exposure_s = 0;  // the exposure actually used
  int width_px = 0;       // 0 when the driver does not know without decoding
  int height_px = 0;
  absl::Time camera_time = absl::InfinitePast();  // unknown if InfinitePast
  // The camera's name for the file ("IMG_0042.JPG"); "" when unknown.
  std::string camera_file_name;
  StoredTo stored_to = StoredTo::kUnknown;
};

// Whether the camera is there. A plain driver is always "connected" (its
// calls fail when the camera is gone); ReconnectingCamera
// (hardware/reconnecting_camera.h) notices a drop and reopens the camera.
struct ConnectionState {
  bool connected = true;
  // While not connected: the reopen attempt under way or waited for (1 =
  // the first after the drop, or after a first open that failed).
  int attempt = 0;
  // How often the camera dropped since it was first opened; a caller that
  // reads it before and after a failed call knows whether the call failed
  // because the camera went away.
  int64_t drops = 0;
  // Why it dropped (or could not be opened at first), then why the last
  // reopen attempt failed; OK when connected.
  absl::Status last_error;
};

// A call that timed out and that the driver could not get back (e.g.
// libgphoto2 did not return when asked to cancel) holds the camera's
// connection until it returns, which may be never: drivers mark its error,
// and those of calls refused meanwhile, with CameraStuckError.
// ReconnectingCamera (hardware/reconnecting_camera.h) treats such an error
// as a drop. The status keeps its code (DEADLINE_EXCEEDED, UNAVAILABLE).
inline constexpr char kCameraStuckPayloadUrl[] =
    "type.hdrstereo.org/hdrstereo.hardware.CameraStuck";
inline absl::Status CameraStuckError(absl::Status status) {
  status.SetPayload(kCameraStuckPayloadUrl, absl::Cord());
  return status;
}
inline bool IsCameraStuck(const absl::Status& status) {
  return status.GetPayload(kCameraStuckPayloadUrl).has_value();
}

// Every call blocks until done or its timeout; none throws. Errors:
// UNAVAILABLE (no camera, disconnected, busy beyond the retries),
// DEADLINE_EXCEEDED (timed out), INVALID_ARGUMENT (a setting the camera does
// not offer), DATA_LOSS (a transfer that arrived corrupt).
class Camera {
 public:
  virtual ~Camera() = default;

  virtual absl::StatusOr<CameraInfo> Info() = 0;
  // Applies `settings`; returns the settings now in effect (e.g. the nearest
  // shutter speed the camera offers).
  virtual absl::StatusOr<ExposureSettings> Configure(
      const ExposureSettings& settings) = 0;
  virtual absl::StatusOr<ExposureSettings> Settings() = 0;
  // Captures with the current settings and downloads the file.
  virtual absl::StatusOr<Frame> Capture() = 0;
  // Call before a group of captures: points the capture target at the
  // camera's RAM (where Capture() expects files) and discards the events
  // and files the camera still holds from before, so that the next Capture()
  // returns the next image, not an old one. Returns how many files it
  // discarded.
  virtual absl::StatusOr<int> PrepareCaptureGroup() = 0;
  // One live-view frame: what the sensor sees now at the current settings,
  // reduced (a few hundred pixels wide), as JPEG bytes; nothing is stored
  // on the camera. Live view may change the camera's state (a DSLR's mirror
  // stays up): the next Capture() leaves it first. UNIMPLEMENTED for a
  // camera without live view (the default).
  virtual absl::StatusOr<Frame> Preview() {
    return absl::UnimplementedError("this camera has no live view");
  }
  // Thread-safe and cheap (never talks to the camera), so it may be asked
  // while another thread holds the camera in a capture.
  virtual ConnectionState Connection() const { return {}; }
};

}  // namespace hdrstereo::hardware

#endif  // HDRSTEREO_HARDWARE_CAMERA_H_
