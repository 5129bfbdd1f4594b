// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/projector_probe.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include "absl/cleanup/cleanup.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"
#include "daemon/jobs/device_log.h"
#include "daemon/store/event_kind.h"
#include "processing/base/status_macros.h"
#include "processing/exposure/frame_statistics.h"

namespace hdrstereo::jobs {
namespace {

constexpr double kDefaultStepS = 0.02;
constexpr double kDefaultMaxDelayS = 0.5;
constexpr double kDefaultExposureS = 1.0 / 125;
constexpr double kMaxStepS = 1;
constexpr double kMaxDelayS = 10;
constexpr double kMaxExposureS = 30;
// How close to a whole number of refresh periods an exposure must be.
constexpr double kPeriodTolerance = 0.02;

// "0.12 s" for people.
std::string Seconds(absl::Duration d) {
  return absl::StrFormat("%g s", absl::ToDoubleSeconds(d));
}

}  // namespace

absl::StatusOr<ProbeOptions> ProbeOptionsFrom(
    const v1::ProjectorProbeOptions& proto, absl::string_view field) {
  auto check = [&](double value, absl::string_view name, double max,
                   double fallback) -> absl::StatusOr<double> {
    if (value == 0) return fallback;
    if (!std::isfinite(value) || value < 0 || value > max) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s.%s is %g; use 0 (%g s) or a time in (0, %g] s",
                          field, name, value, fallback, max));
    }
    return value;
  };
  ASSIGN_OR_RETURN(const double step,
                   check(proto.step_s(), "step_s", kMaxStepS, kDefaultStepS));
  ASSIGN_OR_RETURN(
      const double max_delay,
      check(proto.max_delay_s(), "max_delay_s", kMaxDelayS, kDefaultMaxDelayS));
  ASSIGN_OR_RETURN(const double exposure,
                   check(proto.exposure_s(), "exposure_s", kMaxExposureS,
                         kDefaultExposureS));
  if (max_delay < step) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s.max_delay_s (%g s) is shorter than %s.step_s (%g s)", field,
        max_delay, field, step));
  }
  // Steps 0, step, ... up to max_delay (a rounding error's worth beyond).
  if (std::floor(max_delay / step + 1e-9) + 1 > kMaxProbeSteps) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: %g s in steps of %g s are more than %d frames; use a larger "
        "step_s or a smaller max_delay_s",
        field, max_delay, step, kMaxProbeSteps));
  }
  return ProbeOptions{.step = absl::Seconds(step),
                      .max_delay = absl::Seconds(max_delay),
                      .exposure_s = exposure};
}

v1::ProjectorProbeOptions ToProto(const ProbeOptions& options) {
  v1::ProjectorProbeOptions proto;
  proto.set_step_s(absl::ToDoubleSeconds(options.step));
  proto.set_max_delay_s(absl::ToDoubleSeconds(options.max_delay));
  proto.set_exposure_s(options.exposure_s);
  return proto;
}

absl::StatusOr<ProbeResult> SearchLatency(const ProbeOptions& options,
                                          double black_level,
                                          double white_level,
                                          const LevelAfter& level_after) {
  if (white_level - black_level < kMinProbeContrast) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "the camera does not see the projector: a frame of white (mean "
        "level %.1f) is not brighter than one of black (%.1f) by %g levels, "
        "each taken %s after the pattern was shown; is the projector on and "
        "pointed at the scene the camera sees, or is its latency longer than "
        "max_delay_s?",
        white_level, black_level, kMinProbeContrast,
        Seconds(options.max_delay)));
  }
  ProbeResult result;
  result.step = options.step;
  result.black_level = black_level;
  result.white_level = white_level;
  result.white_from =
      black_level + kWhiteFraction * (white_level - black_level);
  for (int i = 0;; ++i) {
    const absl::Duration delay = options.step * i;
    if (delay > options.max_delay + absl::Microseconds(1)) break;
    ASSIGN_OR_RETURN(const double level, level_after(delay));
    result.steps.push_back(
        {.delay = delay, .level = level, .white = level >= result.white_from});
    if (result.steps.back().white) {
      result.latency = delay;
      return result;
    }
  }
  return absl::OutOfRangeError(absl::StrFormat(
      "no frame was white up to %s after the white pattern was shown (mean "
      "levels: black %.1f, white %.1f, last probe %.1f): the projector's "
      "latency is longer; raise max_delay_s",
      Seconds(options.max_delay), black_level, white_level,
      result.steps.empty() ? black_level : result.steps.back().level));
}

absl::StatusOr<ProbeResult> ProbeProjectorLatency(
    hardware::Camera& camera, hardware::Projector& projector,
    const ProbeOptions& options,
    const std::function<absl::Status()>& checkpoint) {
  using store::Device;
  ASSIGN_OR_RETURN(const hardware::ExposureSettings before,
                   MarkDeviceError(Device::kCamera, camera.Settings()));
  RETURN_IF_ERROR(MarkDeviceError(
      Device::kCamera, camera
                           .Configure({.exposure_s = options.exposure_s,
                                       .iso = 0,
                                       .aperture_f = 0,
                                       .format = hardware::ImageFormat::kJpeg})
                           .status()));
  absl::Cleanup restore = [&] {
    projector.Blank().IgnoreError();
    if (before.exposure_s > 0) camera.Configure(before).IgnoreError();
  };
  const cv::Mat white(projector.resolution(), CV_8UC1, cv::Scalar(255));
  // A frame `delay` after `pattern` (black when empty) was shown.
  auto level_after = [&](const cv::Mat& pattern,
                         absl::Duration delay) -> absl::StatusOr<double> {
    RETURN_IF_ERROR(checkpoint());
    RETURN_IF_ERROR(MarkDeviceError(
        Device::kProjector,
        pattern.empty() ? projector.Blank() : projector.Show(pattern)));
    absl::SleepFor(delay);
    ASSIGN_OR_RETURN(const hardware::Frame frame,
                     MarkDeviceError(Device::kCamera, camera.Capture()));
    ASSIGN_OR_RETURN(const exposure::FrameStatistics stats,
                     exposure::ComputeEncodedFrameStatistics(frame.bytes));
    return stats.MeanLevel();
  };
  ASSIGN_OR_RETURN(const double black,
                   level_after(cv::Mat(), options.max_delay));
  ASSIGN_OR_RETURN(const double white_level,
                   level_after(white, options.max_delay));
  return SearchLatency(
      options, black, white_level,
      [&](absl::Duration delay) -> absl::StatusOr<double> {
        // Black long enough to show whatever the latency (up
        // to the longest delay tried), then white.
        RETURN_IF_ERROR(MarkDeviceError(Device::kProjector, projector.Blank()));
        absl::SleepFor(options.max_delay);
        return level_after(white, delay);
      });
}

bool IsWholeRefreshPeriods(double exposure_s, double refresh_hz) {
  const double periods = exposure_s * refresh_hz;
  return periods >= 1 - kPeriodTolerance &&
         std::abs(periods - std::round(periods)) <= kPeriodTolerance;
}

double RoundToRefreshPeriods(double exposure_s, double refresh_hz) {
  return std::max(1.0, std::round(exposure_s * refresh_hz)) / refresh_hz;
}

absl::StatusOr<absl::Duration> PrepareProjectorTiming(
    const v1::StructuredLightPlan& plan, hardware::Camera& camera,
    hardware::Projector& projector, JobContext& context,
    store::FrameRepository& frames, int64_t capture_id) {
  std::optional<double> refresh_hz;
  if (absl::StatusOr<double> hz = projector.RefreshHz(); hz.ok()) {
    refresh_hz = *hz;
    std::vector<std::string> off;
    for (double e : plan.exposures_s()) {
      if (!IsWholeRefreshPeriods(e, *hz)) off.push_back(absl::StrCat(e));
    }
    if (off.empty()) {
      context.Info(absl::StrFormat(
          "display refresh %.2f Hz: every exposure lasts whole periods", *hz));
    } else {
      context.Warn(absl::StrFormat(
          "display refresh %.2f Hz (period %.2f ms): exposure(s) %s s are "
          "not a whole number of periods, so a pattern change may show in "
          "part of a frame; submit with round_exposures_to_refresh "
          "(--round-to-refresh) to round them",
          *hz, 1000 / *hz, absl::StrJoin(off, ", ")));
    }
  } else {
    context.Warn(absl::StrCat("the display's refresh rate is unknown (",
                              hz.status().message(),
                              "); exposures are not checked against it"));
  }
  std::optional<double> latency_s;
  absl::Duration wait;
  ASSIGN_OR_RETURN(const store::ProjectorTiming recorded,
                   frames.ProjectorTimingOf(capture_id));
  if (plan.has_projector_probe() && recorded.latency_s.has_value()) {
    // A resumed capture keeps the timing its frames were taken with.
    latency_s = recorded.latency_s;
    wait = absl::Seconds(*latency_s);
    context.Info(absl::StrFormat(
        "projector latency %s, as probed when the capture started: each "
        "frame waits that long after its pattern",
        Seconds(wait)));
  } else if (plan.has_projector_probe()) {
    ASSIGN_OR_RETURN(const ProbeOptions options,
                     ProbeOptionsFrom(plan.projector_probe(),
                                      "structured_light.projector_probe"));
    context.Info(absl::StrFormat(
        "probing the projector's latency: delays 0 to %s in steps of %s",
        Seconds(options.max_delay), Seconds(options.step)));
    ASSIGN_OR_RETURN(const ProbeResult probe,
                     ProbeProjectorLatency(camera, projector, options, [&] {
                       return context.Checkpoint();
                     }));
    wait = probe.latency;
    latency_s = absl::ToDoubleSeconds(probe.latency);
    context.Info(absl::StrFormat(
        "projector latency %s (probed in steps of %s; mean levels black "
        "%.1f, white %.1f): each frame waits that long after its pattern",
        Seconds(probe.latency), Seconds(probe.step), probe.black_level,
        probe.white_level));
  }
  RETURN_IF_ERROR(frames.SetProjectorTiming(
      capture_id, {.latency_s = latency_s, .refresh_hz = refresh_hz}));
  return wait;
}

}  // namespace hdrstereo::jobs
