// SPDX-License-Identifier: GPL-3.0-or-later
//
// Checks each downloaded frame against what was asked of the camera, using
// what the camera itself wrote into the file (EXIF for JPEG/PNG/TIFF,
// LibRaw's metadata for RAW) and the file's name and place on the camera.
// It catches the failures that corrupt a dataset without any error:
//   - another exposure (more than 1/6 stop off), ISO or f-number than set;
//   - the previous image delivered again (identical bytes, the same file
//     name with the same camera time, or the same sub-second camera time);
//   - a file stored on the card although the capture target is RAM.
// A field the file does not carry is not checked (and recorded as unknown).
#ifndef HDRSTEREO_DAEMON_JOBS_FRAME_CHECK_H_
#define HDRSTEREO_DAEMON_JOBS_FRAME_CHECK_H_

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "daemon/store/event_kind.h"
#include "hardware/camera.h"

namespace hdrstereo::jobs {

// What the camera says about one frame.
struct CameraReport {
  std::optional<double> exposure_s;
  std::optional<double> iso;
  std::optional<double> aperture_f;
  std::optional<int64_t> time_ms;  // EXIF time, else the driver's file time
  bool time_has_subseconds = false;
  std::string file_name;
  hardware::StoredTo stored_to = hardware::StoredTo::kUnknown;
  std::string sha256;  // of the delivered bytes
};

// Reads the report from a delivered frame (hashes its bytes).
CameraReport ReadCameraReport(const hardware::Frame& frame);

struct Mismatch {
  // kPreviousFile, kCardTarget, kWrongExposure, kWrongIso or kWrongAperture.
  store::EventKind kind = store::EventKind::kNone;
  std::string message;  // names the expected and the reported value
};

// Exposure tolerance: 1/6 stop.
inline constexpr double kExposureToleranceStops = 1.0 / 6;

class FrameChecker {
 public:
  // Frames already accepted in this capture (e.g. recorded before a
  // restart), so that a camera answering with one of them is caught.
  void Remember(const CameraReport& report);
  // nullopt when `report` matches `requested` (the settings Configure
  // returned as in effect) and is not a frame seen before.
  std::optional<Mismatch> Check(const hardware::ExposureSettings& requested,
                                const CameraReport& report) const;

 private:
  std::set<std::string> hashes_;
  std::set<std::pair<std::string, int64_t>> names_and_times_;
  std::set<int64_t> precise_times_;
};

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_FRAME_CHECK_H_
