// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/capture_plan.h"

#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_replace.h"
#include "daemon/jobs/projector_probe.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::jobs {
namespace {

namespace sl = structured_light;

absl::Status CheckExposures(
    const google::protobuf::RepeatedField<double>& exposures,
    absl::string_view field) {
  if (exposures.size() > kMaxExposures) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, " has ", exposures.size(), " exposures; at most ",
                     kMaxExposures));
  }
  for (int i = 0; i < exposures.size(); ++i) {
    const double e = exposures[i];
    if (!std::isfinite(e) || e <= 0 || e > 3600) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s[%d] is %g s; exposures must be in (0, 3600] s", field, i, e));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckGeometry(double baseline_mm, int views, double settle_s,
                           const RigLimits& rig, absl::string_view prefix) {
  if (views < 1 || views > kMaxViews) {
    return absl::InvalidArgumentError(
        absl::StrCat(prefix, ".views is ", views, "; use 1 to ", kMaxViews));
  }
  if (!std::isfinite(baseline_mm) || baseline_mm < 0 ||
      (views > 1 && baseline_mm == 0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s.baseline_mm is %g; it must be > 0", prefix, baseline_mm));
  }
  const double last = rig.home_position_mm + (views - 1) * baseline_mm;
  if (last > rig.travel_mm + 1e-9) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: %d views %g mm apart from %g mm end at %g mm, beyond the stage "
        "travel of %g mm",
        prefix, views, baseline_mm, rig.home_position_mm, last, rig.travel_mm));
  }
  if (!std::isfinite(settle_s) || settle_s < 0 || settle_s > 60) {
    return absl::InvalidArgumentError(
        absl::StrFormat("%s.settle_s is %g; use 0 to 60 s", prefix, settle_s));
  }
  return absl::OkStatus();
}

absl::Status CheckCamera(int iso, double aperture_f, absl::string_view prefix) {
  if (iso < 0 || iso > 409600) {
    return absl::InvalidArgumentError(
        absl::StrCat(prefix, ".iso is ", iso, "; use 0 (camera's) to 409600"));
  }
  if (!std::isfinite(aperture_f) || aperture_f < 0 || aperture_f > 64) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s.aperture_f is %g; use 0 (camera's) to 64", prefix, aperture_f));
  }
  return absl::OkStatus();
}

// Zero fields from hdr::AutoBracketOptions' defaults, then its rules. The
// step's default depends on the frames: linear ones (16-bit TIFF, RAW) take
// the library's, 8-bit ones and the camera's own format (usually JPEG) the
// closer hdr::kMaxStepStops8Bit.
absl::Status NormalizeAutoBracket(v1::ImageFormat format, v1::AutoBracket* a) {
  const hdr::AutoBracketOptions defaults;
  if (a->min_snr() == 0) a->set_min_snr(defaults.min_snr);
  if (a->max_step_stops() == 0) {
    const bool linear = format == v1::IMAGE_FORMAT_TIFF_16 ||
                        format == v1::IMAGE_FORMAT_RAW ||
                        format == v1::IMAGE_FORMAT_RAW_AND_JPEG;
    a->set_max_step_stops(linear ? defaults.max_step_stops
                                 : hdr::kMaxStepStops8Bit);
  }
  return WithFieldPrefix("bracketed_stereo.auto_bracket",
                         AutoBracketOptionsOf(*a).Validate());
}

}  // namespace

bool ChoosesExposuresAtTheRig(const v1::CapturePlan& plan) {
  return plan.has_bracketed_stereo() &&
         plan.bracketed_stereo().has_auto_bracket() &&
         plan.bracketed_stereo().exposures_s().empty();
}

hdr::AutoBracketOptions AutoBracketOptionsOf(const v1::AutoBracket& a) {
  return {.min_snr = a.min_snr(),
          .max_step_stops = a.max_step_stops(),
          .exclude_emitters_above = a.exclude_emitters_above(),
          .max_uncovered_fraction = a.max_uncovered_fraction(),
          .max_exposure_s = a.max_exposure_s()};
}

v1::CapturePlan WithChosenExposures(v1::CapturePlan plan,
                                    const hdr::AutoBracketResult& chosen) {
  google::protobuf::RepeatedField<double>* exposures =
      plan.mutable_bracketed_stereo()->mutable_exposures_s();
  exposures->Clear();
  for (double e : chosen.exposures_s) exposures->Add(e);
  return plan;
}

absl::StatusOr<std::optional<hdr::AutoBracketResult>> RecordedAutoBracket(
    const std::string& whose, const std::string& json) {
  if (json.empty()) return std::nullopt;
  absl::StatusOr<hdr::AutoBracketResult> chosen =
      hdr::AutoBracketFromJson(json);
  if (!chosen.ok()) {
    return absl::DataLossError(
        absl::StrCat(whose, ": ", chosen.status().message()));
  }
  return std::move(*chosen);
}

v1::CapturePlan WithDefaultExposures(v1::CapturePlan plan) {
  if (!ChoosesExposuresAtTheRig(plan)) return plan;
  for (double e : v1::kDefaultStereoExposuresS) {
    plan.mutable_bracketed_stereo()->add_exposures_s(e);
  }
  return plan;
}

void ToProto(const hdr::AutoBracketResult& chosen, v1::AutoBracketChoice* out) {
  for (double e : chosen.exposures_s) out->add_exposures_s(e);
  out->set_reason(chosen.Reason());
  out->set_scene_range_stops(chosen.SceneStops());
  out->set_camera_range_stops(chosen.CameraStops());
  out->set_coverage(chosen.Coverage());
  out->set_pixels(chosen.pixels);
  out->set_emitter_pixels(chosen.emitter_pixels);
  out->set_emitter_fraction(chosen.EmitterFraction());
  out->set_min_snr(chosen.min_snr);
  out->set_full_well_e(chosen.noise.full_well_e);
  out->set_read_noise_e(chosen.noise.read_noise_e);
  out->set_probes(chosen.probes);
}

absl::StatusOr<io::CaptureKind> PlanKind(const v1::CapturePlan& plan) {
  switch (plan.plan_case()) {
    case v1::CapturePlan::kBracketedStereo:
      return io::CaptureKind::kBracketedStereo;
    case v1::CapturePlan::kStructuredLight:
      return io::CaptureKind::kStructuredLight;
    case v1::CapturePlan::kCalibration:
      return io::CaptureKind::kCalibration;
    case v1::CapturePlan::PLAN_NOT_SET:
      break;
  }
  return absl::InvalidArgumentError(
      "plan must be one of bracketed_stereo, structured_light, calibration");
}

absl::StatusOr<v1::CapturePlan> NormalizePlan(const v1::CapturePlan& plan,
                                              const RigLimits& rig) {
  v1::CapturePlan out = plan;
  switch (plan.plan_case()) {
    case v1::CapturePlan::kBracketedStereo: {
      v1::BracketedStereoPlan* p = out.mutable_bracketed_stereo();
      RETURN_IF_ERROR(
          CheckExposures(p->exposures_s(), "bracketed_stereo.exposures_s"));
      if (p->has_auto_bracket()) {
        if (!p->exposures_s().empty()) {
          return absl::InvalidArgumentError(
              "bracketed_stereo: give exposures_s or auto_bracket, not both "
              "(automatic bracketing chooses the exposures)");
        }
        RETURN_IF_ERROR(
            NormalizeAutoBracket(p->format(), p->mutable_auto_bracket()));
      } else if (p->exposures_s().empty()) {
        for (double e : v1::kDefaultStereoExposuresS) p->add_exposures_s(e);
      }
      if (p->views() == 0) p->set_views(v1::kDefaultViews);
      if (p->baseline_mm() == 0 && p->views() > 1) {
        p->set_baseline_mm(v1::kDefaultBaselineMm);
      }
      RETURN_IF_ERROR(CheckGeometry(p->baseline_mm(), p->views(), p->settle_s(),
                                    rig, "bracketed_stereo"));
      RETURN_IF_ERROR(
          CheckCamera(p->iso(), p->aperture_f(), "bracketed_stereo"));
      if (!v1::ImageFormat_IsValid(p->format())) {
        return absl::InvalidArgumentError(
            "bracketed_stereo.format is not a known format");
      }
      return out;
    }
    case v1::CapturePlan::kStructuredLight: {
      v1::StructuredLightPlan* p = out.mutable_structured_light();
      RETURN_IF_ERROR(
          CheckExposures(p->exposures_s(), "structured_light.exposures_s"));
      if (p->exposures_s().empty()) {
        for (double e : v1::kDefaultStructuredLightExposuresS) {
          p->add_exposures_s(e);
        }
      }
      if (p->views() == 0) p->set_views(v1::kDefaultViews);
      if (p->baseline_mm() == 0 && p->views() > 1) {
        p->set_baseline_mm(v1::kDefaultBaselineMm);
      }
      RETURN_IF_ERROR(CheckGeometry(p->baseline_mm(), p->views(), p->settle_s(),
                                    rig, "structured_light"));
      RETURN_IF_ERROR(
          CheckCamera(p->iso(), p->aperture_f(), "structured_light"));
      if (p->has_projector_probe()) {
        ASSIGN_OR_RETURN(const ProbeOptions probe,
                         ProbeOptionsFrom(p->projector_probe(),
                                          "structured_light.projector_probe"));
        *p->mutable_projector_probe() = ToProto(probe);
      }
      if (p->round_exposures_to_refresh()) {
        if (!(rig.projector_refresh_hz > 0)) {
          return absl::FailedPreconditionError(
              "structured_light.round_exposures_to_refresh: the projector "
              "does not report its display's refresh rate");
        }
        for (double& e : *p->mutable_exposures_s()) {
          e = RoundToRefreshPeriods(e, rig.projector_refresh_hz);
        }
      }
      return out;
    }
    case v1::CapturePlan::kCalibration: {
      v1::CalibrationPlan* p = out.mutable_calibration();
      if (p->poses() < 1 || p->poses() > kMaxCalibrationPoses) {
        return absl::InvalidArgumentError(
            absl::StrCat("calibration.poses is ", p->poses(), "; use 1 to ",
                         kMaxCalibrationPoses));
      }
      if (p->exposure_s() == 0) {
        p->set_exposure_s(v1::kDefaultCalibrationExposureS);
      }
      if (!std::isfinite(p->exposure_s()) || p->exposure_s() < 0) {
        return absl::InvalidArgumentError("calibration.exposure_s must be > 0");
      }
      if (p->baseline_mm() == 0) p->set_baseline_mm(v1::kDefaultBaselineMm);
      RETURN_IF_ERROR(
          CheckGeometry(p->baseline_mm(), 2, 0, rig, "calibration"));
      if (p->board_columns() == 0)
        p->set_board_columns(v1::kDefaultBoardColumns);
      if (p->board_rows() == 0) p->set_board_rows(v1::kDefaultBoardRows);
      if (p->board_square_mm() == 0) {
        p->set_board_square_mm(v1::kDefaultBoardSquareMm);
      }
      // OpenCV finds boards of at least 3 x 3 inner corners.
      for (const auto& [name, corners] :
           {std::pair{"board_columns", p->board_columns()},
            std::pair{"board_rows", p->board_rows()}}) {
        if (corners < 3 || corners > kMaxBoardCorners) {
          return absl::InvalidArgumentError(
              absl::StrCat("calibration.", name, " is ", corners,
                           " inner corners; use 3 to ", kMaxBoardCorners));
        }
      }
      if (!std::isfinite(p->board_square_mm()) || p->board_square_mm() < 0 ||
          p->board_square_mm() > kMaxBoardSquareMm) {
        return absl::InvalidArgumentError(absl::StrCat(
            "calibration.board_square_mm is ", p->board_square_mm(),
            "; use a size in mm above 0 and up to ", kMaxBoardSquareMm));
      }
      return out;
    }
    case v1::CapturePlan::PLAN_NOT_SET:
      break;
  }
  return absl::InvalidArgumentError(
      "plan must be one of bracketed_stereo, structured_light, calibration");
}

std::vector<FrameSpec> ExpandPlan(const v1::CapturePlan& plan,
                                  const RigLimits& rig, int64_t capture_id) {
  std::vector<FrameSpec> frames;
  auto add = [&](int view, int views, double stage_mm, io::FrameKey key,
                 std::optional<sl::Pattern> pattern) {
    FrameSpec f;
    f.sequence = static_cast<int>(frames.size());
    f.view_index = view;
    f.stage_position_mm = stage_mm;
    f.exposure_s = key.exposure_s;
    f.role = key.role;
    f.projector_blank = !pattern.has_value();
    f.pattern = pattern;
    f.relative_stem = io::FrameStem(capture_id, io::ViewName(view, views), key);
    frames.push_back(std::move(f));
  };
  auto exposure = [](io::FrameRole role, double seconds) {
    io::FrameKey key;
    key.role = role;
    key.exposure_s = seconds;
    return key;
  };
  switch (plan.plan_case()) {
    case v1::CapturePlan::kBracketedStereo: {
      const v1::BracketedStereoPlan& p = plan.bracketed_stereo();
      if (!p.skip_ambient() && !p.exposures_s().empty()) {
        // One frame of the scene as it is (projector dark) before anything
        // moves, at the middle of the bracket.
        const double mid = p.exposures_s(p.exposures_s_size() / 2);
        add(0, p.views(), rig.home_position_mm,
            exposure(io::FrameRole::kAmbient, mid), std::nullopt);
      }
      for (int v = 0; v < p.views(); ++v) {
        const double x = rig.home_position_mm + v * p.baseline_mm();
        for (double e : p.exposures_s()) {
          add(v, p.views(), x, exposure(io::FrameRole::kStereo, e),
              std::nullopt);
        }
      }
      break;
    }
    case v1::CapturePlan::kStructuredLight: {
      const v1::StructuredLightPlan& p = plan.structured_light();
      const std::vector<sl::Pattern> patterns =
          sl::AllPatterns(rig.projector_size);
      for (int v = 0; v < p.views(); ++v) {
        const double x = rig.home_position_mm + v * p.baseline_mm();
        for (double e : p.exposures_s()) {
          for (const sl::Pattern& pattern : patterns) {
            io::FrameKey key = exposure(io::FrameRole::kStructuredLight, e);
            key.pattern = pattern.Id();
            key.inverse = pattern.inverse;
            add(v, p.views(), x, std::move(key), pattern);
          }
        }
      }
      break;
    }
    case v1::CapturePlan::kCalibration: {
      const v1::CalibrationPlan& p = plan.calibration();
      for (int pose = 0; pose < p.poses(); ++pose) {
        for (int v = 0; v < 2; ++v) {
          io::FrameKey key =
              exposure(io::FrameRole::kCalibration, p.exposure_s());
          key.pose = pose;
          add(v, 2, rig.home_position_mm + v * p.baseline_mm(), std::move(key),
              std::nullopt);
        }
      }
      break;
    }
    case v1::CapturePlan::PLAN_NOT_SET:
      break;
  }
  return frames;
}

double ExpectedSeconds(const std::vector<FrameSpec>& frames,
                       const BaseSettings& settings, const RigLimits& rig,
                       const CaptureTiming& timing) {
  double seconds = 0;
  double at_mm = rig.home_position_mm;
  // The pattern on the projector: its id and whether it is the inverse.
  std::optional<std::pair<std::string, bool>> shown;
  for (const FrameSpec& frame : frames) {
    if (frame.stage_position_mm != at_mm) {
      seconds +=
          std::abs(frame.stage_position_mm - at_mm) / timing.stage_speed_mm_s +
          settings.settle_s;
      at_mm = frame.stage_position_mm;
    }
    if (frame.pattern.has_value()) {
      std::pair<std::string, bool> pattern{frame.pattern->Id(),
                                           frame.pattern->inverse};
      if (pattern != shown) {
        seconds += timing.pattern_change_s;
        shown = std::move(pattern);
      }
    }
    seconds += frame.exposure_s + timing.frame_overhead_s;
  }
  return seconds;
}

BaseSettings SettingsOf(const v1::CapturePlan& plan) {
  BaseSettings base;
  switch (plan.plan_case()) {
    case v1::CapturePlan::kBracketedStereo: {
      const auto& p = plan.bracketed_stereo();
      base = {p.iso(), p.aperture_f(), std::nullopt, p.settle_s()};
      switch (p.format()) {
        case v1::IMAGE_FORMAT_JPEG:
          base.format = hardware::ImageFormat::kJpeg;
          break;
        case v1::IMAGE_FORMAT_RAW:
        case v1::IMAGE_FORMAT_RAW_AND_JPEG:
          base.format = hardware::ImageFormat::kRaw;
          break;
        case v1::IMAGE_FORMAT_TIFF_16:
          base.format = hardware::ImageFormat::kTiff16;
          break;
        case v1::IMAGE_FORMAT_PNG_8:
          base.format = hardware::ImageFormat::kPng8;
          break;
        default:
          break;
      }
      break;
    }
    case v1::CapturePlan::kStructuredLight: {
      const auto& p = plan.structured_light();
      base = {p.iso(), p.aperture_f(), std::nullopt, p.settle_s()};
      break;
    }
    default:
      break;
  }
  return base;
}

}  // namespace hdrstereo::jobs
