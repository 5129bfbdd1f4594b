// SPDX-License-Identifier: GPL-3.0-or-later
//
// The calibration capture's own work: whether a frame shows the plan's
// chessboard, live-view guidance while the operator places a pose, and,
// after the last pose, the rig's calibration computed from the poses and
// stored as the rig's latest (processing rectifies with it).
#ifndef HDRSTEREO_DAEMON_JOBS_RIG_CALIBRATION_H_
#define HDRSTEREO_DAEMON_JOBS_RIG_CALIBRATION_H_

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/container/flat_hash_map.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/store/frame_repository.h"
#include "hardware/camera.h"
#include "hdrstereo/v1/jobs.pb.h"
#include "processing/calib/stereo_calibration.h"

namespace hdrstereo::jobs {

// The chessboard a calibration plan names (0 fields: the defaults).
calib::BoardSpec BoardOf(const v1::CalibrationPlan& plan);

// Why a calibration frame does not show `board` ("" when it does, or when
// the frame is RAW and cannot be checked here).
std::string BoardMissing(const hardware::Frame& frame,
                         const calib::BoardSpec& board);

// After the last pose of a calibration capture: calibrates the rig from
// its poses and stores the result as the rig's latest calibration (files
// under rig/calibrations/<capture id>/ of the data root, written
// atomically, and a row in rig_calibrations). Fewer than 3 poses, or frames
// it cannot read (RAW), leave the rig as it was, with a warning.
absl::Status CalibrateRig(JobContext& context, store::FrameRepository& frames,
                          const store::CaptureRecord& capture,
                          const std::filesystem::path& session_dir, int poses,
                          const calib::BoardSpec& board);

// What live view tells the operator placing a calibration board.
struct PoseGuide {
  int64_t job_id = 0;
  int pose = 0;   // the pose asked for, 1-based
  int poses = 0;  // of this many
  // The board's inner corners in the live-view frame (empty: not found,
  // and board_missing says why).
  std::vector<cv::Point2f> corners;
  std::string board_missing;
  int poses_kept = 0;
  // Fractions of the image the kept poses' corner hulls cover, per view,
  // and the left view's with this frame's board added.
  double coverage_left = 0, coverage_right = 0;
  double coverage_with_this_pose = 0;
};

// Guides the operator while a calibration capture waits for a pose: finds
// the board in live-view frames and measures what the poses kept so far
// cover. The corners of a kept frame are found once and remembered (for
// the job being guided only). Thread-safe.
class CalibrationGuide {
 public:
  explicit CalibrationGuide(store::Store& store) : store_(store) {}

  // For `job`, a capture waiting for the operator: nullopt unless it is a
  // calibration. `preview` is a live-view frame (any size; the job shows
  // the pose's left view while it waits).
  absl::StatusOr<std::optional<PoseGuide>> Guide(const store::JobRecord& job,
                                                 const cv::Mat& preview);

 private:
  // A kept frame's corners as fractions of its width and height.
  absl::StatusOr<std::vector<cv::Point2f>> CornersOf(
      const store::FrameRecord& frame, const std::filesystem::path& dir,
      const calib::BoardSpec& board) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);

  store::Store& store_;
  absl::Mutex mutex_;
  int64_t job_id_ ABSL_GUARDED_BY(mutex_) = 0;
  absl::flat_hash_map<int64_t, std::vector<cv::Point2f>> corners_
      ABSL_GUARDED_BY(mutex_);
};

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_RIG_CALIBRATION_H_
