// SPDX-License-Identifier: GPL-3.0-or-later
//
// Runs a capture job on the rig: the frames of its plan, each written
// atomically and recorded in the same transaction that advances progress.
// A resumed job verifies what is recorded (sha256) and takes only what is
// missing.
#ifndef HDRSTEREO_DAEMON_JOBS_CAPTURE_JOB_H_
#define HDRSTEREO_DAEMON_JOBS_CAPTURE_JOB_H_

#include <filesystem>
#include <functional>

#include "absl/status/status.h"
#include "absl/time/time.h"
#include "daemon/jobs/capture_plan.h"
#include "daemon/jobs/disk_guard.h"
#include "daemon/jobs/frame_boundary.h"
#include "daemon/jobs/job_engine.h"
#include "hardware/rig.h"

namespace hdrstereo::jobs {

// The rig's limits as capture plans see them; FAILED_PRECONDITION when the
// stage is missing.
absl::StatusOr<RigLimits> LimitsOf(const hardware::Rig& rig);

// FAILED_PRECONDITION naming the missing device when `plan` cannot run on
// `rig` as it is now.
absl::Status CheckDevicesFor(const v1::CapturePlan& plan,
                             const hardware::Rig& rig);

// Validates and normalises `plan` against the rig, checks its devices and
// (with `disk`) that its frames fit on the data root (RESOURCE_EXHAUSTED
// otherwise), and queues a capture job for `session` on behalf of
// `submitted_by`: what Jobs.SubmitCapture and the scheduler both do.
absl::StatusOr<store::JobRecord> SubmitCapture(JobEngine& engine,
                                               const hardware::Rig& rig,
                                               absl::string_view session,
                                               const v1::CapturePlan& plan,
                                               absl::string_view submitted_by,
                                               const DiskGuard* disk = nullptr);

// What SubmitCapture would queue for `plan` (Jobs.EstimateCapture): the
// plan judged as SubmitCapture judges it (the same errors), and, for a plan
// whose exposures are chosen at the rig, the default bracket's frames (what
// the disk guard promises room for until then).
struct CaptureEstimate {
  int64_t frames = 0;
  double duration_s = 0;   // ExpectedSeconds
  int64_t disk_bytes = 0;  // DiskGuard::NeededBytes
  bool exposures_chosen_at_rig = false;
};
absl::StatusOr<CaptureEstimate> EstimateCapture(const hardware::Rig& rig,
                                                const v1::CapturePlan& plan,
                                                const DiskGuard& disk);

// Writes the exact truth of a stereo pair taken at `left_mm` and
// `left_mm + baseline_mm` into `dir` (simulation only).
using TruthWriter = std::function<absl::Status(
    double left_mm, double baseline_mm, const std::filesystem::path& dir)>;

// Puts the calibration board in pose `pose` (0-based) when a calibration
// capture asks the operator for it (simulation only: the simulated operator
// places the board; at a real rig the person does).
using BoardPlacer = std::function<absl::Status(int pose)>;

// The job runner for capture jobs (JobKind::kCapture); the job's request is
// a serialized, normalised v1::CapturePlan. With `write_truth`, a finished
// bracketed-stereo capture also gets its truth in io::TruthDir.
// Before each frame, `conditions` are checked (and the camera, stage and
// projector asked whether they still answer); a frame is taken only into
// conditions that hold.
// A calibration capture moves the stage to the pose's first view, calls
// `place_board` (simulation) and waits for the operator before each pose
// (JobContext::WaitForOperator, "place the board in pose 3 of 8 and
// continue"; live view guides the board meanwhile); a pose whose frames
// do not show the chessboard (calib::BoardSpec's inner corners; RAW frames
// are not checked) is not kept: its frames are dropped and the pose is
// waited for again, the event and the instruction saying so. A pose left
// half taken by a restart is taken again whole.
absl::Status RunCaptureJob(hardware::Rig& rig, JobContext& context,
                           const TruthWriter& write_truth = nullptr,
                           const CaptureConditions& conditions = {},
                           const BoardPlacer& place_board = nullptr);

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_CAPTURE_JOB_H_
