// SPDX-License-Identifier: GPL-3.0-or-later
//
// A capture plan (jobs.proto) validated, completed with defaults, and
// expanded into the exact, ordered list of frames to take. The same list is
// computed again when an interrupted capture resumes, so a frame's sequence
// number identifies it across restarts.
#ifndef HDRSTEREO_DAEMON_JOBS_CAPTURE_PLAN_H_
#define HDRSTEREO_DAEMON_JOBS_CAPTURE_PLAN_H_

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "hardware/camera.h"
#include "hdrstereo/v1/jobs.pb.h"
#include "processing/hdr/auto_bracket.h"
#include "processing/io/capture_layout.h"
#include "processing/structured_light/gray_code.h"
#include "proto/hdrstereo/v1/capture_defaults.h"

namespace hdrstereo::jobs {

inline constexpr int kMaxExposures = 64;
inline constexpr int kMaxViews = 16;
inline constexpr int kMaxCalibrationPoses = 64;
inline constexpr int kMaxBoardCorners = 100;  // along either side
inline constexpr double kMaxBoardSquareMm = 1000;

struct RigLimits {
  double travel_mm = 150;
  double home_position_mm = 0;
  cv::Size projector_size{1024, 768};
  double projector_refresh_hz = 0;  // 0: unknown
};

// The camera settings a plan asks for besides the exposure (0 and nullopt:
// the camera's own), and the stage's settle time after a move.
struct BaseSettings {
  int iso = 0;
  double aperture_f = 0;
  std::optional<hardware::ImageFormat> format;
  double settle_s = 0;
};

BaseSettings SettingsOf(const v1::CapturePlan& plan);

// One frame of a capture.
struct FrameSpec {
  int sequence = 0;
  int view_index = 0;
  double stage_position_mm = 0;
  double exposure_s = 0;
  io::FrameRole role = io::FrameRole::kStereo;
  std::optional<structured_light::Pattern> pattern;  // structured light only
  bool projector_blank = true;  // false only with a pattern
  // Path relative to the session folder, without the extension (the camera
  // decides it): io::FrameStem.
  std::string relative_stem;
};

// Checks `plan` against the rig and fills in defaults (an auto_bracket's
// from hdr::AutoBracketOptions). INVALID_ARGUMENT naming the field for
// anything out of range; nothing is changed then.
absl::StatusOr<v1::CapturePlan> NormalizePlan(const v1::CapturePlan& plan,
                                              const RigLimits& rig);

// Whether the plan's exposures are chosen at the rig (auto_bracket): its
// frames are known only then (ExpandPlan after ChosenExposures).
bool ChoosesExposuresAtTheRig(const v1::CapturePlan& plan);
// The options of a normalised plan's auto_bracket.
hdr::AutoBracketOptions AutoBracketOptionsOf(
    const v1::AutoBracket& auto_bracket);
// The plan with the exposures automatic bracketing chose.
v1::CapturePlan WithChosenExposures(v1::CapturePlan plan,
                                    const hdr::AutoBracketResult& chosen);
// A plan that chooses its exposures at the rig with the thesis' default
// bracket in their place (other plans as they are): the frames room on
// disk is promised for until it has chosen.
v1::CapturePlan WithDefaultExposures(v1::CapturePlan plan);
// The choice a capture recorded (captures.auto_bracket, `json`; nullopt
// when it has none), DATA_LOSS naming `whose` ("capture 3") when it cannot
// be read.
absl::StatusOr<std::optional<hdr::AutoBracketResult>> RecordedAutoBracket(
    const std::string& whose, const std::string& json);
// The choice as the wire shows it (Job.auto_bracket).
void ToProto(const hdr::AutoBracketResult& chosen, v1::AutoBracketChoice* out);

// The frames of a normalised plan, in capture order (a plan that chooses
// its exposures at the rig has none before WithChosenExposures).
std::vector<FrameSpec> ExpandPlan(const v1::CapturePlan& plan,
                                  const RigLimits& rig, int64_t capture_id);

// What a rig takes to capture, for telling people how long a plan lasts
// (Jobs.EstimateCapture): a DSLR's readout and USB transfer of one frame, a
// lead-screw stage's speed, a projector's pattern change.
struct CaptureTiming {
  double frame_overhead_s = 1.0;  // per frame, besides its exposure
  double stage_speed_mm_s = 20;
  double pattern_change_s = 0.1;  // each frame whose pattern differs
};

// About how long `frames` (ExpandPlan) take with `settings` (SettingsOf):
// each frame's exposure and overhead, each stage move (from the home
// position to the first frame's, then between frames) at the stage's speed
// plus the plan's settle time, each pattern change. Not counted: the
// operator a calibration waits for, metering and projector probes,
// retaken frames, suspensions.
double ExpectedSeconds(const std::vector<FrameSpec>& frames,
                       const BaseSettings& settings, const RigLimits& rig,
                       const CaptureTiming& timing = {});

// What the plan captures; INVALID_ARGUMENT for a plan without one.
absl::StatusOr<io::CaptureKind> PlanKind(const v1::CapturePlan& plan);

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_CAPTURE_PLAN_H_
