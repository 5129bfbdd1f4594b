// SPDX-License-Identifier: GPL-3.0-or-later
//
// Automatic bracketing at the rig: a capture whose plan asks for it meters
// the scene with linear probe frames before its first frame and takes the
// exposures hdr::MeterAndChoose chooses (processing/hdr/auto_bracket.h has
// the model); the choice is recorded with the capture.
#ifndef HDRSTEREO_DAEMON_JOBS_METERING_H_
#define HDRSTEREO_DAEMON_JOBS_METERING_H_

#include <functional>

#include "absl/status/statusor.h"
#include "daemon/jobs/capture_plan.h"
#include "daemon/jobs/device_log.h"
#include "daemon/jobs/frame_boundary.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/store/frame_repository.h"
#include "hardware/camera.h"
#include "hardware/projector.h"
#include "hardware/stage.h"
#include "hdrstereo/v1/jobs.pb.h"

namespace hdrstereo::jobs {

// The exposures of a plan with auto_bracket: those its capture chose
// before (a resumed or resubmitted capture takes the same frames), else
// the scene is metered now (hdr::MeterAndChoose; probes at most
// kMaxAttemptsPerFrame times after transient faults), the choice refused
// when it leaves too much uncovered (hdr::AcceptCoverage: the job fails
// before any frame) and recorded with the capture.
absl::StatusOr<v1::CapturePlan> ChooseExposures(
    JobContext& context, store::FrameRepository& frames,
    const store::CaptureRecord& capture, hardware::Camera& camera,
    hardware::Stage& stage, hardware::Projector* projector, DeviceLog& devices,
    const CaptureConditions& conditions,
    const std::function<absl::Status(double)>& place_stage,
    const std::function<void()>& home_again, const v1::CapturePlan& plan,
    const RigLimits& limits, const BaseSettings& base);

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_METERING_H_
