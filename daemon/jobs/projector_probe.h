// SPDX-License-Identifier: GPL-3.0-or-later
//
// Projector timing: how long after a pattern was shown the camera sees it
// (the projector's input latency beyond what Projector::Show already
// waits), and whether structured-light exposures last whole refresh periods
// of the display (SLStudio #8, #24: a pattern changes on a refresh; an
// exposure that is not a whole number of periods sees one pattern more or
// less often than the other).
//
// The probe shows black, then white, and takes a frame `delay` after the
// white pattern was shown, for delay = 0, step, 2 step, ... up to
// max_delay; the latency is the first delay whose frame is white: its mean
// level at least kWhiteFraction of the way from the black reference to the
// white one (each reference taken max_delay after its pattern was shown).
// Used by Hardware.ProbeProjector and, as a step of a structured-light
// capture, by RunCaptureJob.
#ifndef HDRSTEREO_DAEMON_JOBS_PROJECTOR_PROBE_H_
#define HDRSTEREO_DAEMON_JOBS_PROJECTOR_PROBE_H_

#include <cstdint>
#include <functional>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/store/frame_repository.h"
#include "hardware/camera.h"
#include "hardware/projector.h"
#include "hdrstereo/v1/hardware.pb.h"
#include "hdrstereo/v1/jobs.pb.h"

namespace hdrstereo::jobs {

// How far between the references a frame must be to count as white.
inline constexpr double kWhiteFraction = 0.9;
// The white reference must be this many levels (of 255) above the black
// one, or the camera does not see the projector.
inline constexpr double kMinProbeContrast = 2.0;
inline constexpr int kMaxProbeSteps = 100;

struct ProbeOptions {
  absl::Duration step = absl::Milliseconds(20);
  absl::Duration max_delay = absl::Milliseconds(500);
  double exposure_s = 1.0 / 125;
};

// The options `proto` asks for, defaults for its zeros. INVALID_ARGUMENT
// naming the field (as "<field>.step_s") when one is out of range.
absl::StatusOr<ProbeOptions> ProbeOptionsFrom(
    const v1::ProjectorProbeOptions& proto, absl::string_view field);
// `options` as a proto with every field set.
v1::ProjectorProbeOptions ToProto(const ProbeOptions& options);

struct ProbeStep {
  absl::Duration delay;
  double level = 0;  // mean level of the frame (0..255)
  bool white = false;
};

struct ProbeResult {
  absl::Duration latency;  // the delay of the first white frame
  absl::Duration step;
  double black_level = 0;
  double white_level = 0;
  double white_from = 0;         // the level from which a frame counts as white
  std::vector<ProbeStep> steps;  // in the order taken; the last is white
};

// The mean level of a frame taken `delay` after the projector went from
// black to white.
using LevelAfter = std::function<absl::StatusOr<double>(absl::Duration delay)>;

// The search, given the two reference levels: tries the delays in
// increasing order and stops at the first white frame. FAILED_PRECONDITION
// when the references are less than kMinProbeContrast apart (the camera
// does not see the projector, or its latency exceeds max_delay);
// OUT_OF_RANGE when no frame up to max_delay is white. Errors of
// `level_after` end the search.
absl::StatusOr<ProbeResult> SearchLatency(const ProbeOptions& options,
                                          double black_level,
                                          double white_level,
                                          const LevelAfter& level_after);

// The probe on the rig: the references, then SearchLatency. The frames are
// JPEG at options.exposure_s; the camera's settings are restored and the
// projector left black afterwards. `checkpoint` is called before each frame
// (a cancelled call or job stops the probe with its status). The caller
// holds the hardware lane.
absl::StatusOr<ProbeResult> ProbeProjectorLatency(
    hardware::Camera& camera, hardware::Projector& projector,
    const ProbeOptions& options,
    const std::function<absl::Status()>& checkpoint);

// Whether `exposure_s` lasts a whole number (at least one) of periods of
// `refresh_hz`, within 2 % of a period.
bool IsWholeRefreshPeriods(double exposure_s, double refresh_hz);
// The nearest whole number of refresh periods, at least one.
double RoundToRefreshPeriods(double exposure_s, double refresh_hz);

// The structured-light capture's projector step, before its first frame:
// reads the refresh rate (a warning when unknown) and warns about each
// exposure that is not a whole number of its periods; with
// plan.projector_probe, probes the latency (events say what it found).
// Records both with the capture (FrameRepository::SetProjectorTiming) and
// returns how long each frame must wait after its pattern was shown (zero
// without the probe).
absl::StatusOr<absl::Duration> PrepareProjectorTiming(
    const v1::StructuredLightPlan& plan, hardware::Camera& camera,
    hardware::Projector& projector, JobContext& context,
    store::FrameRepository& frames, int64_t capture_id);

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_PROJECTOR_PROBE_H_
