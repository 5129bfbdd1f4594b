// SPDX-License-Identifier: GPL-3.0-or-later
//
// A capture's frame boundaries: what must hold before a frame is taken (the
// suspenders: camera connected and charged, stage answering without fault
// flags, projector on screen, room on disk), and what a failed attempt at a
// frame, or at a step before the frames, leads to (taken again after a
// transient fault or once a dropped camera is back, else the job fails).
#ifndef HDRSTEREO_DAEMON_JOBS_FRAME_BOUNDARY_H_
#define HDRSTEREO_DAEMON_JOBS_FRAME_BOUNDARY_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "daemon/jobs/device_log.h"
#include "daemon/jobs/disk_guard.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/store/event_kind.h"
#include "hardware/camera.h"
#include "hardware/projector.h"
#include "hardware/stage.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::jobs {

// A frame whose camera drops (or whose projector is lost) more often than
// this while it is taken fails the job (a device that drops at every frame
// is broken, not unplugged).
inline constexpr int kMaxDropsPerFrame = 3;
// A frame (or the parking of the rig after the last one) whose device calls
// fail with transient faults this often fails the job: a fault that
// returns at every try is not passing.
inline constexpr int kMaxAttemptsPerFrame = 3;

// What must hold at every frame boundary of a capture; while one does not,
// the job is suspended (JobContext::SuspendWhile) and resumes by itself.
struct CaptureConditions {
  // The rest of the plan must fit on the data root (with the guard's
  // margin; DiskGuard::CheckRoomForRest); a frame whose write finds the
  // disk full all the same is taken again after this condition, rather
  // than failing the job. nullptr: not checked.
  const DiskGuard* disk = nullptr;
  // 0 disables; a camera that does not report its battery passes.
  int min_battery_percent = 0;
  absl::Duration poll = absl::Seconds(1);
};

// `status` with `step` (what the call was doing) before its message; the
// code and payloads (the device error kind, a stalled move) are kept.
absl::Status InStep(absl::string_view step, const absl::Status& status);
template <typename T>
absl::StatusOr<T> InStep(absl::string_view step, absl::StatusOr<T> result) {
  if (result.ok()) return result;
  return InStep(step, result.status());
}

// The failed attempts at one frame (or at parking the rig): a transient
// device fault (IsTransientDeviceError) is warned about, counted as the
// device error it is, and the frame taken again from its start, until the
// frame has failed kMaxAttemptsPerFrame times; then, or at once for a
// permanent fault, the job fails with every attempt named.
class Attempts {
 public:
  // `what` begins each message ("frame left view, ..."), `again` says what
  // is done after a transient fault ("the frame is taken again from its
  // start"), `outcome` what a failure leaves ("nothing was recorded for
  // it").
  Attempts(JobContext& context, std::string what, std::string again,
           std::string outcome)
      : context_(context),
        what_(std::move(what)),
        again_(std::move(again)),
        outcome_(std::move(outcome)) {}

  // `failed`: the error of a device call, marked with its kind by DeviceLog
  // and named by its step (InStep). OK when it is to be tried again, else
  // the job's error.
  absl::Status Retry(const absl::Status& failed);

  const std::string& what() const { return what_; }
  const std::string& again() const { return again_; }

 private:
  JobContext& context_;
  const std::string what_;
  const std::string again_;
  const std::string outcome_;
  std::vector<std::string> failures_;  // each attempt's error
};

// Whether the camera dropped (its drop count moved past `drops_before`) or
// is away: a step that failed then is taken again once it is back.
bool CameraDropped(hardware::Camera& camera, int64_t drops_before);

// A step (`what`: "frame left view, ...") that failed with `failed` while
// the camera dropped: counted in `drops` and OK after the warning "`what`:
// the camera dropped (...); `again` once it is back"; the job's error
// (kCameraDisconnected) when the step has already seen kMaxDropsPerFrame
// drops.
absl::Status OnCameraDrop(JobContext& context, absl::string_view what,
                          absl::string_view again, const absl::Status& failed,
                          int* drops);

// A step taken at a frame boundary before the frames (a metering probe,
// the projector's timing), as a frame is taken: the frames' suspenders
// (`blocking`, polled every `poll`) are waited for first; a camera that
// drops while the step runs is waited for at the boundary and the step
// taken again, at most kMaxDropsPerFrame times; a transient device fault
// takes it again (`attempts`, whose what() and again() also word the
// drop's messages); anything else fails the job. `start_over`
// runs after a suspension, a drop or a fault: what the step relies on
// (the stage homed, the camera prepared) is to be done again.
template <typename T>
absl::StatusOr<T> TakeBeforeFrames(
    JobContext& context, hardware::Camera& camera, Attempts& attempts,
    const std::function<std::string()>& blocking, absl::Duration poll,
    const std::function<void()>& start_over,
    const std::function<absl::StatusOr<T>()>& step) {
  for (int drops = 0;;) {
    RETURN_IF_ERROR(context.Checkpoint());
    bool was_suspended = false;
    RETURN_IF_ERROR(context.SuspendWhile(
        [&] {
          std::string why = blocking();
          was_suspended = was_suspended || !why.empty();
          return why;
        },
        poll));
    if (was_suspended) start_over();
    const int64_t drops_before = camera.Connection().drops;
    absl::StatusOr<T> result = step();
    if (result.ok()) return result;
    if (CameraDropped(camera, drops_before)) {
      RETURN_IF_ERROR(OnCameraDrop(context, attempts.what(), attempts.again(),
                                   result.status(), &drops));
      start_over();
      continue;
    }
    RETURN_IF_ERROR(attempts.Retry(result.status()));
    start_over();
  }
}

// What the disk condition asks at a frame boundary.
struct DiskNeed {
  int64_t frames = 0;  // not written yet; a frame being written counts
  int64_t bytes_per_frame = 0;
  // Why the last write of a frame found the disk full ("" when none did):
  // said first, so that the suspension names it.
  std::string write_failure;
};

// Why the next frame cannot be taken now ("" when it can): the suspenders,
// asked at every frame boundary. `projector`: the one the plan needs
// (structured light), else nullptr. The queries are device calls, timed in
// `devices` like the others.
std::string BlockingCondition(const CaptureConditions& conditions,
                              hardware::Camera& camera, hardware::Stage& stage,
                              hardware::Projector* projector,
                              const DiskNeed& disk_need, DeviceLog& devices);

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_FRAME_BOUNDARY_H_
