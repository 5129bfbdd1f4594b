// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/metering.h"

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/cleanup/cleanup.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/base/status_macros.h"
#include "processing/hdr/merge.h"
#include "processing/io/capture_layout.h"
#include "processing/io/image.h"

namespace hdrstereo::jobs {
namespace {

// One linear probe of automatic bracketing at `exposure_s`, the stage at
// the view's position: in 16-bit TIFF where the camera offers it (the
// simulator), else RAW (LibRaw decodes it linear); written to the job's
// folder (jobs/<job>/probes/, kept for people, never a frame of the
// dataset) and returned as float, full scale 1.
class ProbeCamera {
 public:
  ProbeCamera(JobContext& context, hardware::Camera& camera, DeviceLog& devices,
              const BaseSettings& base)
      : context_(context), camera_(camera), devices_(devices), base_(base) {}

  absl::StatusOr<cv::Mat> Take(absl::string_view view, double exposure_s) {
    ASSIGN_OR_RETURN(const hardware::ExposureSettings applied,
                     Configure(exposure_s));
    ASSIGN_OR_RETURN(
        const hardware::Frame frame,
        InStep("capturing", devices_.Sample(store::Device::kCamera, [&] {
          return camera_.Capture();
        })));
    const std::string relative = absl::StrFormat(
        "jobs/%d/probes/%s/%02d_%s.%s", context_.job().id, view, ++taken_,
        io::ExposureTag(applied.exposure_s), frame.extension);
    RETURN_IF_ERROR(context_.store().files().WriteSessionFile(
        context_.job().session, relative, frame.bytes));
    ASSIGN_OR_RETURN(const io::DecodedImage decoded,
                     io::DecodeImageFile(context_.store().files().SessionDir(
                                             context_.job().session) /
                                         relative));
    if (decoded.pixels.depth() != CV_16U) {
      return absl::DataLossError(absl::StrCat(
          "probe ", relative, " is not 16-bit: it cannot be read as linear"));
    }
    return io::ToFloat(decoded.pixels);
  }

 private:
  absl::StatusOr<hardware::ExposureSettings> Configure(double exposure_s) {
    auto configure = [&](hardware::ImageFormat format) {
      return InStep(
          absl::StrCat("setting the exposure to ", io::ExposureTag(exposure_s)),
          devices_.Time(store::Device::kCamera, [&] {
            return camera_.Configure({.exposure_s = exposure_s,
                                      .iso = base_.iso,
                                      .aperture_f = base_.aperture_f,
                                      .format = format});
          }));
    };
    if (format_.has_value()) return configure(*format_);
    absl::StatusOr<hardware::ExposureSettings> tiff =
        configure(hardware::ImageFormat::kTiff16);
    if (!absl::IsInvalidArgument(tiff.status())) {
      format_ = hardware::ImageFormat::kTiff16;
      return tiff;
    }
    absl::StatusOr<hardware::ExposureSettings> raw =
        configure(hardware::ImageFormat::kRaw);
    if (absl::IsInvalidArgument(raw.status())) {
      return absl::FailedPreconditionError(absl::StrCat(
          "automatic bracketing meters with linear probes, 16-bit TIFF or "
          "RAW, and the camera offers neither: ",
          tiff.status().message(), "; ", raw.status().message()));
    }
    format_ = hardware::ImageFormat::kRaw;
    return raw;
  }

  JobContext& context_;
  hardware::Camera& camera_;
  DeviceLog& devices_;
  const BaseSettings& base_;
  std::optional<hardware::ImageFormat> format_;  // decided by the first
  int taken_ = 0;
};

}  // namespace

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
    const RigLimits& limits, const BaseSettings& base) {
  ASSIGN_OR_RETURN(const std::optional<hdr::AutoBracketResult> recorded,
                   RecordedAutoBracket(absl::StrCat("capture ", capture.id),
                                       capture.auto_bracket));
  if (recorded.has_value()) {
    context.Info(
        absl::StrCat("automatic bracket chosen before: ", recorded->Reason()));
    return WithChosenExposures(plan, *recorded);
  }
  const v1::BracketedStereoPlan& stereo = plan.bracketed_stereo();
  const hdr::AutoBracketOptions options =
      AutoBracketOptionsOf(stereo.auto_bracket());
  ASSIGN_OR_RETURN(const hardware::CameraInfo info,
                   InStep("asking the camera for its shutter speeds",
                          devices.Time(store::Device::kCamera,
                                       [&] { return camera.Info(); })));
  std::vector<double> choices =
      info.shutter_speeds_s.empty()
          ? hdr::ThirdStopShutterSpeeds(info.min_exposure_s,
                                        info.max_exposure_s)
          : info.shutter_speeds_s;
  if (options.max_exposure_s > 0) {
    std::erase_if(choices, [&](double t) {
      return t > options.max_exposure_s * (1 + 1e-9);
    });
  }
  if (choices.empty()) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "automatic bracketing has no shutter speed to choose from: the "
        "camera offers %g .. %g s%s",
        info.min_exposure_s, info.max_exposure_s,
        options.max_exposure_s > 0
            ? absl::StrFormat(", auto_bracket.max_exposure_s is %g s",
                              options.max_exposure_s)
            : ""));
  }
  // The frames come in the camera's own format again afterwards.
  ASSIGN_OR_RETURN(
      const hardware::ExposureSettings before,
      devices.Time(store::Device::kCamera, [&] { return camera.Settings(); }));
  absl::Cleanup restore = [&] {
    devices
        .Time(store::Device::kCamera,
              [&] {
                return camera.Configure(
                    {.exposure_s = before.exposure_s, .format = before.format});
              })
        .IgnoreError();
  };
  if (projector != nullptr) {
    RETURN_IF_ERROR(InStep("blanking the projector",
                           devices.Sample(store::Device::kProjector,
                                          [&] { return projector->Blank(); })));
  }
  RETURN_IF_ERROR(InStep("preparing the camera",
                         devices
                             .Time(store::Device::kCamera,
                                   [&] { return camera.PrepareCaptureGroup(); })
                             .status()));
  ProbeCamera probes(context, camera, devices, base);
  bool prepare_again = false;  // after the camera dropped
  auto take = [&](int view, double exposure_s) -> absl::StatusOr<cv::Mat> {
    const std::string name = io::ViewName(view, stereo.views());
    const std::string what = absl::StrCat(
        "metering the ", name, " view: probe at ", io::ExposureTag(exposure_s));
    // The frames' suspenders hold for probes too: a rig unfit for a frame
    // (camera gone or its battery low, stage flags, disk short) is waited
    // for at this boundary, not probed.
    Attempts attempts(context, what, "the probe is taken again",
                      "no frame was taken");
    return TakeBeforeFrames<cv::Mat>(
        context, camera, attempts,
        [&] {
          return BlockingCondition(conditions, camera, stage, nullptr, {},
                                   devices);
        },
        conditions.poll,
        [&] {
          // The stage may have been touched, or faulted: home it again; a
          // camera that came back has its own settings, perhaps files.
          home_again();
          prepare_again = true;
        },
        [&]() -> absl::StatusOr<cv::Mat> {
          RETURN_IF_ERROR(context.Progress(0, 0, what));
          if (prepare_again) {
            RETURN_IF_ERROR(
                InStep("preparing the camera",
                       devices
                           .Time(store::Device::kCamera,
                                 [&] { return camera.PrepareCaptureGroup(); })
                           .status()));
            prepare_again = false;
          }
          RETURN_IF_ERROR(place_stage(limits.home_position_mm +
                                      view * stereo.baseline_mm()));
          return probes.Take(name, exposure_s);
        });
  };
  absl::StatusOr<hdr::AutoBracketResult> chosen =
      hdr::MeterAndChoose(stereo.views(), take, choices,
                          hdr::MergeOptions().linear_saturation, options);
  if (!chosen.ok()) return InStep("automatic bracketing", chosen.status());
  RETURN_IF_ERROR(hdr::AcceptCoverage(*chosen, options));
  RETURN_IF_ERROR(
      frames.SetAutoBracket(capture.id, nlohmann::json(*chosen).dump()));
  context.Info(absl::StrCat("automatic bracket: ", chosen->Reason(), " (",
                            chosen->probes, " probe frames in jobs/",
                            context.job().id, "/probes/)"));
  return WithChosenExposures(plan, *chosen);
}

}  // namespace hdrstereo::jobs
