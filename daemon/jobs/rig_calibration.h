// SPDX-License-Identifier: GPL-3.0-or-later
//
// The calibration capture's own work: whether a frame shows the plan's
// chessboard, and, after the last pose, the rig's calibration computed from
// the poses and stored as the rig's latest (processing rectifies with it).
#ifndef HDRSTEREO_DAEMON_JOBS_RIG_CALIBRATION_H_
#define HDRSTEREO_DAEMON_JOBS_RIG_CALIBRATION_H_

#include <filesystem>
#include <string>

#include "absl/status/status.h"
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

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_RIG_CALIBRATION_H_
