// SPDX-License-Identifier: GPL-3.0-or-later
//
// Captures and their frames (tables `captures` and `frames`). Kinds and
// formats are stored by name (io::CaptureKindName,
// hardware::ImageFormatName); a row with another name is DATA_LOSS.
#ifndef HDRSTEREO_DAEMON_STORE_FRAME_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_FRAME_REPOSITORY_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/store/store.h"
#include "hardware/camera.h"
#include "processing/io/capture_layout.h"

namespace hdrstereo::store {

struct CaptureRecord {
  int64_t id = 0;
  int64_t session_id = 0;
  int64_t job_id = 0;
  io::CaptureKind kind = io::CaptureKind::kBracketedStereo;
  std::string plan;  // serialized CapturePlan
  // What automatic bracketing chose (hdr::AutoBracketResult's canonical
  // JSON; "" when the plan did not ask or has not chosen yet).
  std::string auto_bracket;
};

// What a structured-light capture measured of its projector: the latency
// its probe found (nullopt: not probed), the refresh rate of the display
// (nullopt: unknown).
struct ProjectorTiming {
  std::optional<double> latency_s;
  std::optional<double> refresh_hz;
};

struct FrameRecord {
  int64_t id = 0;
  int64_t capture_id = 0;
  io::CaptureKind capture_kind = io::CaptureKind::kBracketedStereo;
  int sequence = 0;
  int view_index = 0;
  double stage_position_mm = 0;
  double exposure_s = 0;
  std::string pattern;  // e.g. "col_b03", "white", "" for none
  bool inverse = false;
  hardware::ImageFormat format = hardware::ImageFormat::kJpeg;
  int width_px = 0;
  int height_px = 0;
  std::string path;  // relative to the session folder
  std::string sha256;
  std::optional<int64_t> camera_time_ms;
  // What the camera reported (EXIF, or LibRaw for RAW); nullopt when the
  // file carries no such field.
  std::optional<double> camera_exposure_s;
  std::optional<double> iso;
  std::optional<double> aperture_f;
  std::string camera_file_name;  // "" when the camera does not say
};

class FrameRepository {
 public:
  explicit FrameRepository(Store& store) : store_(store) {}

  // The capture a job records into: found again when the job resumes; a
  // job resubmitted with the same plan after a failure or cancellation
  // continues the earlier job's capture (only missing frames are taken).
  absl::StatusOr<CaptureRecord> CaptureForJob(int64_t job_id,
                                              io::CaptureKind kind,
                                              absl::string_view plan);
  absl::StatusOr<std::vector<FrameRecord>> FramesOfCapture(int64_t capture_id);
  // The frames of the capture a job records into, by sequence (none when
  // the job has no capture yet).
  absl::StatusOr<std::vector<FrameRecord>> FramesOfJob(int64_t job_id);
  // Records what automatic bracketing chose for the capture (before its
  // first frame; a resumed capture keeps it).
  absl::Status SetAutoBracket(int64_t capture_id, absl::string_view json);
  // The automatic bracket of the capture a job records into ("" when
  // none); NOT_FOUND when the job has no capture.
  absl::StatusOr<std::string> AutoBracketOfJob(int64_t job_id);
  // The projector timing recorded with a capture; NOT_FOUND for an unknown
  // capture.
  absl::Status SetProjectorTiming(int64_t capture_id,
                                  const ProjectorTiming& timing);
  absl::StatusOr<ProjectorTiming> ProjectorTimingOf(int64_t capture_id);
  // The capture a job records into; NOT_FOUND when it has none yet.
  absl::StatusOr<int64_t> CaptureIdOfJob(int64_t job_id);
  // The captures of a session ordered by id. NOT_FOUND for an unknown
  // session.
  absl::StatusOr<std::vector<CaptureRecord>> CapturesOfSession(
      absl::string_view session);
  // Frames of a session (optionally one capture), ordered by id, after
  // `after_id`, at most `limit`. NOT_FOUND for an unknown session.
  absl::StatusOr<std::vector<FrameRecord>> FramesOfSession(
      absl::string_view session, int64_t capture_id, int64_t after_id,
      int limit);

  // Inside a transaction the caller holds (checked at run time: callers
  // reach it through callbacks the analysis cannot follow).
  absl::Status InsertLocked(const FrameRecord& frame);
  absl::Status Delete(int64_t frame_id);

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_FRAME_REPOSITORY_H_
