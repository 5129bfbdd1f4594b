// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/hardware_service.h"

#include <google/protobuf/util/time_util.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"
#include "daemon/jobs/projector_probe.h"
#include "daemon/rpc/status.h"
#include "processing/base/status_macros.h"
#include "processing/exposure/frame_statistics.h"
#include "processing/io/image.h"
#include "processing/structured_light/gray_code.h"

namespace hdrstereo::rpc {
namespace {

namespace sl = structured_light;

constexpr int kMaxIso = 409600;
constexpr double kMaxApertureF = 64;

// A device that is unreachable is a precondition of the call, not the
// daemon being unavailable: clients treat UNAVAILABLE as "no daemon". So
// is a device that cannot do what is asked (UNIMPLEMENTED would read as a
// method the daemon does not serve).
grpc::Status DeviceError(const absl::Status& status) {
  if (absl::IsUnavailable(status) || absl::IsUnimplemented(status)) {
    return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                        std::string(status.message()));
  }
  return ToGrpcStatus(status);
}

grpc::Status Missing(absl::string_view device, const absl::Status& why) {
  return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                      absl::StrCat("no ", device, ": ", why.message()));
}

std::optional<hardware::ImageFormat> FromProto(v1::ImageFormat format) {
  switch (format) {
    case v1::IMAGE_FORMAT_JPEG:
      return hardware::ImageFormat::kJpeg;
    case v1::IMAGE_FORMAT_RAW:
      return hardware::ImageFormat::kRaw;
    case v1::IMAGE_FORMAT_RAW_AND_JPEG:
      return hardware::ImageFormat::kRawAndJpeg;
    case v1::IMAGE_FORMAT_TIFF_16:
      return hardware::ImageFormat::kTiff16;
    case v1::IMAGE_FORMAT_PNG_8:
      return hardware::ImageFormat::kPng8;
    default:
      return std::nullopt;
  }
}

v1::ImageFormat ToProto(hardware::ImageFormat format) {
  switch (format) {
    case hardware::ImageFormat::kJpeg:
      return v1::IMAGE_FORMAT_JPEG;
    case hardware::ImageFormat::kRaw:
      return v1::IMAGE_FORMAT_RAW;
    case hardware::ImageFormat::kRawAndJpeg:
      return v1::IMAGE_FORMAT_RAW_AND_JPEG;
    case hardware::ImageFormat::kTiff16:
      return v1::IMAGE_FORMAT_TIFF_16;
    case hardware::ImageFormat::kPng8:
      return v1::IMAGE_FORMAT_PNG_8;
  }
  return v1::IMAGE_FORMAT_UNSPECIFIED;
}

void ToProto(const hardware::ExposureSettings& settings,
             v1::CameraSettings* out) {
  out->set_exposure_s(settings.exposure_s);
  out->set_iso(settings.iso);
  out->set_aperture_f(settings.aperture_f);
  if (settings.format.has_value()) out->set_format(ToProto(*settings.format));
}

// The pattern a request asks for, at projector resolution `size`.
absl::StatusOr<std::pair<cv::Mat, std::string>> PatternFor(
    const v1::ShowPatternRequest& request, cv::Size size) {
  switch (request.pattern_case()) {
    case v1::ShowPatternRequest::kPng: {
      absl::StatusOr<cv::Mat> decoded =
          io::DecodeWithOpenCv(request.png(), cv::IMREAD_UNCHANGED);
      if (!decoded.ok()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "png is not a decodable image: ", decoded.status().message()));
      }
      cv::Mat image = *std::move(decoded);
      if (image.depth() != CV_8U ||
          (image.channels() != 1 && image.channels() != 3)) {
        return absl::InvalidArgumentError(
            "png must be 8-bit gray or RGB (no alpha, no 16-bit)");
      }
      if (image.size() != size) {
        return absl::InvalidArgumentError(
            absl::StrFormat("png is %dx%d; the projector shows exactly %dx%d",
                            image.cols, image.rows, size.width, size.height));
      }
      return std::make_pair(image, std::string("png image"));
    }
    case v1::ShowPatternRequest::kGrayCode: {
      const v1::GrayCodePattern& g = request.gray_code();
      if (g.axis() != v1::GrayCodePattern::AXIS_COLUMNS &&
          g.axis() != v1::GrayCodePattern::AXIS_ROWS) {
        return absl::InvalidArgumentError(
            "gray_code.axis must be AXIS_COLUMNS or AXIS_ROWS");
      }
      sl::Pattern pattern{.kind = sl::Pattern::Kind::kBitPlane,
                          .axis = g.axis() == v1::GrayCodePattern::AXIS_COLUMNS
                                      ? sl::Axis::kColumns
                                      : sl::Axis::kRows,
                          .bit = g.bit(),
                          .inverse = g.inverse()};
      ASSIGN_OR_RETURN(cv::Mat image, sl::Render(pattern, size));
      return std::make_pair(image,
                            absl::StrCat("gray code ", pattern.Id(),
                                         pattern.inverse ? " inverse" : ""));
    }
    case v1::ShowPatternRequest::kSolidLevel:
      if (request.solid_level() < 0 || request.solid_level() > 255) {
        return absl::InvalidArgumentError(absl::StrCat(
            "solid_level is ", request.solid_level(), "; use 0..255"));
      }
      return std::make_pair(
          cv::Mat(size, CV_8UC1, cv::Scalar(request.solid_level())),
          absl::StrCat("solid ", request.solid_level()));
    case v1::ShowPatternRequest::PATTERN_NOT_SET:
      break;
  }
  return absl::InvalidArgumentError("set one of png, gray_code or solid_level");
}

void ToProto(const jobs::RigLockState& state, v1::RigLock* out) {
  using google::protobuf::util::TimeUtil;
  out->set_locked(true);
  out->set_holder(state.holder);
  out->set_note(state.note);
  *out->mutable_lock_time() =
      TimeUtil::MillisecondsToTimestamp(absl::ToUnixMillis(state.lock_time));
  *out->mutable_expire_time() =
      TimeUtil::MillisecondsToTimestamp(absl::ToUnixMillis(state.expire_time));
}

// Fills what the camera's connection says (no camera call, so also while a
// capture holds the lane); true when the camera is away (nothing more to
// ask it).
bool FillCameraConnection(const hardware::Camera& camera,
                          v1::CameraStatus* out) {
  const hardware::ConnectionState link = camera.Connection();
  out->set_disconnects(link.drops);
  if (link.connected) return false;
  out->set_state(v1::DEVICE_STATE_RECONNECTING);
  out->set_reconnect_attempt(link.attempt);
  out->set_message(std::string(link.last_error.message()));
  out->set_battery_percent(-1);
  return true;
}

void ToProto(const exposure::FrameStatistics& stats, v1::PreviewFrame* out) {
  out->set_width_px(stats.width);
  out->set_height_px(stats.height);
  for (const exposure::ChannelStatistics& c : stats.channels) {
    v1::ChannelStatistics* channel = out->add_channels();
    channel->set_channel(c.name);
    channel->mutable_histogram()->Add(c.histogram.begin(), c.histogram.end());
    channel->set_clipped_low(c.clipped_low);
    channel->set_clipped_high(c.clipped_high);
    channel->set_mean(c.mean);
    channel->set_p1(c.p1);
    channel->set_p50(c.p50);
    channel->set_p99(c.p99);
  }
}

google::protobuf::Timestamp TimestampOf(absl::Time time) {
  return google::protobuf::util::TimeUtil::MillisecondsToTimestamp(
      absl::ToUnixMillis(time));
}

}  // namespace

std::string HardwareService::DescribeJob(int64_t job_id) {
  absl::StatusOr<store::JobRecord> job = engine_.repository().Get(job_id);
  return job.ok() ? absl::StrCat("capture job ", job_id, " (session ",
                                 job->session, ")")
                  : absl::StrCat("capture job ", job_id);
}

int64_t HardwareService::CaptureHoldingRigForPreview() {
  const int64_t job = engine_.running_capture();
  if (job == 0) return 0;
  absl::StatusOr<store::JobRecord> record = engine_.repository().Get(job);
  return record.ok() && record->state == store::JobState::kWaiting ? 0 : job;
}

absl::Status HardwareService::CheckNoCapture(bool allow_waiting) {
  const int64_t job =
      allow_waiting ? CaptureHoldingRigForPreview() : engine_.running_capture();
  if (job == 0) return absl::OkStatus();
  return absl::FailedPreconditionError(absl::StrCat(
      "the hardware is in use by a capture job: ", DescribeJob(job),
      "; wait for it or cancel it"));
}

absl::StatusOr<std::unique_lock<std::mutex>> HardwareService::TakeLane(
    bool allow_waiting, absl::Duration wait) {
  const absl::Time deadline = absl::Now() + wait;
  while (true) {
    RETURN_IF_ERROR(CheckNoCapture(allow_waiting));
    std::unique_lock<std::mutex> lane(rig_.lane(), std::try_to_lock);
    if (lane.owns_lock()) return lane;
    // Another direct call or a live-view frame: each holds it briefly.
    if (absl::Now() > deadline) {
      return absl::FailedPreconditionError(absl::StrCat(
          "the hardware stayed busy with other calls (live view, a projector "
          "probe, direct control) for ",
          absl::FormatDuration(wait), "; try again"));
    }
    absl::SleepFor(absl::Milliseconds(2));
  }
}

void HardwareService::FillCamera(v1::CameraStatus* out) {
  hardware::Camera* camera = rig_.camera();
  if (camera == nullptr) {
    out->set_state(v1::DEVICE_STATE_DISCONNECTED);
    out->set_message(std::string(rig_.camera_error().message()));
    out->set_battery_percent(-1);
    return;
  }
  if (FillCameraConnection(*camera, out)) return;
  absl::StatusOr<hardware::CameraInfo> info = camera->Info();
  if (!info.ok()) {
    out->set_state(v1::DEVICE_STATE_FAULT);
    out->set_message(std::string(info.status().message()));
    out->set_battery_percent(-1);
    return;
  }
  out->set_state(v1::DEVICE_STATE_CONNECTED);
  out->set_model(info->model);
  out->set_serial(info->serial);
  out->set_port(info->port);
  out->set_battery_percent(info->battery_percent);
}

void HardwareService::FillStage(v1::StageStatus* out) {
  hardware::Stage* stage = rig_.stage();
  if (stage == nullptr) {
    out->set_state(v1::DEVICE_STATE_DISCONNECTED);
    out->set_message(std::string(rig_.stage_error().message()));
    return;
  }
  out->set_travel_mm(stage->travel_mm());
  absl::StatusOr<hardware::StageState> state = stage->State();
  if (!state.ok()) {
    out->set_state(v1::DEVICE_STATE_FAULT);
    out->set_message(std::string(state.status().message()));
    return;
  }
  out->set_state(state->busy ? v1::DEVICE_STATE_BUSY
                             : v1::DEVICE_STATE_CONNECTED);
  out->set_position_mm(state->position_mm);
  out->set_homed(state->homed);
  for (const std::string& flag : state->warning_flags) {
    out->add_warning_flags(flag);
  }
}

void HardwareService::FillProjector(v1::ProjectorStatus* out) {
  hardware::Projector* projector = rig_.projector();
  if (projector == nullptr) {
    out->set_state(v1::DEVICE_STATE_DISCONNECTED);
    out->set_message(std::string(rig_.projector_error().message()));
    return;
  }
  out->set_state(v1::DEVICE_STATE_CONNECTED);
  out->set_width_px(projector->resolution().width);
  out->set_height_px(projector->resolution().height);
  absl::MutexLock lock(&showing_mutex_);
  out->set_showing(showing_);
}

grpc::Status HardwareService::GetStatus(grpc::ServerContext* context,
                                        const v1::GetHardwareStatusRequest*,
                                        v1::HardwareStatus* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  response->set_hardware_mode(hardware::HardwareModeName(rig_.config().mode));
  // Never long: a live-view frame is waited for, a capture or a probe is
  // reported instead of querying the devices.
  absl::StatusOr<std::unique_lock<std::mutex>> lane =
      TakeLane(false, absl::Seconds(1));
  if (!lane.ok()) {
    const int64_t job = engine_.running_capture();
    for (auto* message : {response->mutable_camera()->mutable_message(),
                          response->mutable_stage()->mutable_message(),
                          response->mutable_projector()->mutable_message()}) {
      *message = job != 0 ? absl::StrCat("in use by ", DescribeJob(job))
                          : "busy with another call (a projector probe, a "
                            "stage move)";
    }
    response->mutable_camera()->set_state(v1::DEVICE_STATE_BUSY);
    response->mutable_stage()->set_state(v1::DEVICE_STATE_BUSY);
    response->mutable_projector()->set_state(v1::DEVICE_STATE_BUSY);
    // A camera being reconnected says so even then (a suspended capture
    // holds the lane while it waits for it).
    if (rig_.camera() != nullptr) {
      FillCameraConnection(*rig_.camera(), response->mutable_camera());
    }
    return grpc::Status::OK;
  }
  FillCamera(response->mutable_camera());
  FillStage(response->mutable_stage());
  FillProjector(response->mutable_projector());
  return grpc::Status::OK;
}

grpc::Status HardwareService::GetCameraSettings(
    grpc::ServerContext* context, const v1::GetCameraSettingsRequest*,
    v1::CameraSettings* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (rig_.camera() == nullptr) return Missing("camera", rig_.camera_error());
  absl::StatusOr<std::unique_lock<std::mutex>> lane = TakeLane(false);
  if (!lane.ok()) return ToGrpcStatus(lane.status());
  absl::StatusOr<hardware::ExposureSettings> settings =
      rig_.camera()->Settings();
  if (!settings.ok()) return DeviceError(settings.status());
  ToProto(*settings, response);
  return grpc::Status::OK;
}

grpc::Status HardwareService::SetCameraSettings(
    grpc::ServerContext* context, const v1::SetCameraSettingsRequest* request,
    v1::CameraSettings* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (!request->has_settings()) {
    return InvalidArgument("settings is required");
  }
  const v1::CameraSettings& s = request->settings();
  if (!std::isfinite(s.exposure_s()) || s.exposure_s() <= 0) {
    return InvalidArgument(absl::StrCat("settings.exposure_s is ",
                                        s.exposure_s(), "; it must be > 0"));
  }
  if (s.iso() < 0 || s.iso() > kMaxIso) {
    return InvalidArgument(absl::StrCat("settings.iso is ", s.iso(),
                                        "; use 0 (unchanged) to ", kMaxIso));
  }
  if (!std::isfinite(s.aperture_f()) || s.aperture_f() < 0 ||
      s.aperture_f() > kMaxApertureF) {
    return InvalidArgument(
        absl::StrCat("settings.aperture_f is ", s.aperture_f(),
                     "; use 0 (unchanged) to ", kMaxApertureF));
  }
  std::optional<hardware::ImageFormat> format = FromProto(s.format());
  if (s.format() != v1::IMAGE_FORMAT_UNSPECIFIED && !format.has_value()) {
    return InvalidArgument(
        absl::StrCat("settings.format ", s.format(), " is not a known format"));
  }
  if (rig_.camera() == nullptr) return Missing("camera", rig_.camera_error());
  absl::StatusOr<std::unique_lock<std::mutex>> lane = TakeLane(false);
  if (!lane.ok()) return ToGrpcStatus(lane.status());

  absl::StatusOr<hardware::CameraInfo> info = rig_.camera()->Info();
  if (!info.ok()) return DeviceError(info.status());
  if (info->max_exposure_s > 0 && (s.exposure_s() < info->min_exposure_s ||
                                   s.exposure_s() > info->max_exposure_s)) {
    return InvalidArgument(absl::StrFormat(
        "settings.exposure_s %g s is outside the camera's range [%g, %g] s",
        s.exposure_s(), info->min_exposure_s, info->max_exposure_s));
  }
  absl::StatusOr<hardware::ExposureSettings> applied =
      rig_.camera()->Configure({.exposure_s = s.exposure_s(),
                                .iso = s.iso(),
                                .aperture_f = s.aperture_f(),
                                .format = format});
  if (!applied.ok()) return DeviceError(applied.status());
  ToProto(*applied, response);
  return grpc::Status::OK;
}

grpc::Status HardwareService::HomeStage(grpc::ServerContext* context,
                                        const v1::HomeStageRequest*,
                                        v1::StageStatus* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (rig_.stage() == nullptr) return Missing("stage", rig_.stage_error());
  absl::StatusOr<std::unique_lock<std::mutex>> lane = TakeLane(false);
  if (!lane.ok()) return ToGrpcStatus(lane.status());
  if (absl::Status s = rig_.stage()->Home(); !s.ok()) return DeviceError(s);
  FillStage(response);
  return grpc::Status::OK;
}

grpc::Status HardwareService::MoveStage(grpc::ServerContext* context,
                                        const v1::MoveStageRequest* request,
                                        v1::StageStatus* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (rig_.stage() == nullptr) return Missing("stage", rig_.stage_error());
  const double travel = rig_.stage()->travel_mm();
  if (!std::isfinite(request->position_mm()) || request->position_mm() < 0 ||
      request->position_mm() > travel) {
    return InvalidArgument(
        absl::StrFormat("position_mm %g is outside the stage travel [0, %g] mm",
                        request->position_mm(), travel));
  }
  absl::StatusOr<std::unique_lock<std::mutex>> lane = TakeLane(false);
  if (!lane.ok()) return ToGrpcStatus(lane.status());
  if (absl::Status s = rig_.stage()->MoveTo(request->position_mm()); !s.ok()) {
    return DeviceError(s);
  }
  FillStage(response);
  return grpc::Status::OK;
}

grpc::Status HardwareService::ShowPattern(grpc::ServerContext* context,
                                          const v1::ShowPatternRequest* request,
                                          v1::ProjectorStatus* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (rig_.projector() == nullptr) {
    return Missing("projector", rig_.projector_error());
  }
  absl::StatusOr<std::pair<cv::Mat, std::string>> pattern =
      PatternFor(*request, rig_.projector()->resolution());
  if (!pattern.ok()) return ToGrpcStatus(pattern.status());
  absl::StatusOr<std::unique_lock<std::mutex>> lane = TakeLane(false);
  if (!lane.ok()) return ToGrpcStatus(lane.status());
  if (absl::Status s = rig_.projector()->Show(pattern->first); !s.ok()) {
    return DeviceError(s);
  }
  {
    absl::MutexLock lock(&showing_mutex_);
    showing_ = pattern->second;
  }
  FillProjector(response);
  return grpc::Status::OK;
}

grpc::Status HardwareService::BlankProjector(grpc::ServerContext* context,
                                             const v1::BlankProjectorRequest*,
                                             v1::ProjectorStatus* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (rig_.projector() == nullptr) {
    return Missing("projector", rig_.projector_error());
  }
  absl::StatusOr<std::unique_lock<std::mutex>> lane = TakeLane(false);
  if (!lane.ok()) return ToGrpcStatus(lane.status());
  if (absl::Status s = rig_.projector()->Blank(); !s.ok()) {
    return DeviceError(s);
  }
  {
    absl::MutexLock lock(&showing_mutex_);
    showing_ = "blank";
  }
  FillProjector(response);
  return grpc::Status::OK;
}

absl::StatusOr<v1::PreviewFrame> HardwareService::TakePreviewFrame() {
  absl::StatusOr<hardware::Frame> frame;
  {
    ASSIGN_OR_RETURN(std::unique_lock<std::mutex> lane,
                     TakeLane(/*allow_waiting=*/true));
    frame = rig_.camera()->Preview();
  }
  RETURN_IF_ERROR(frame.status());
  ASSIGN_OR_RETURN(const exposure::FrameStatistics stats,
                   exposure::ComputeEncodedFrameStatistics(frame->bytes));
  v1::PreviewFrame out;
  ToProto(stats, &out);
  out.set_jpeg(std::move(frame->bytes));
  out.set_exposure_s(frame->exposure_s);
  return out;
}

void HardwareService::GuideCalibration(v1::PreviewFrame* frame) {
  const int64_t job_id = engine_.running_capture();
  if (job_id == 0) return;
  absl::StatusOr<store::JobRecord> job = engine_.repository().Get(job_id);
  if (!job.ok() || job->state != store::JobState::kWaiting) return;
  // An undecodable frame is guided as an empty one (the board not found).
  const cv::Mat image =
      io::DecodeWithOpenCv(frame->jpeg(), cv::IMREAD_GRAYSCALE)
          .value_or(cv::Mat());
  absl::StatusOr<std::optional<jobs::PoseGuide>> guide =
      guide_.Guide(*job, image);
  if (!guide.ok()) {
    // Live view goes on without the guide.
    spdlog::warn("live view: no calibration guide for job {}: {}", job_id,
                 guide.status().ToString());
    return;
  }
  if (!guide->has_value()) return;
  const jobs::PoseGuide& g = **guide;
  v1::CalibrationGuide* out = frame->mutable_calibration();
  out->set_job_id(g.job_id);
  out->set_pose(g.pose);
  out->set_poses(g.poses);
  out->set_board_found(!g.corners.empty());
  out->set_board_missing(g.board_missing);
  out->set_poses_kept(g.poses_kept);
  out->set_coverage_left(g.coverage_left);
  out->set_coverage_right(g.coverage_right);
  out->set_coverage_with_this_pose(g.coverage_with_this_pose);
}

grpc::Status HardwareService::StreamPreview(
    grpc::ServerContext* context, const v1::StreamPreviewRequest* request,
    grpc::ServerWriter<v1::PreviewMessage>* writer) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  const double max_fps = request->max_fps();
  if (!std::isfinite(max_fps) || max_fps < 0) {
    return InvalidArgument(absl::StrFormat(
        "max_fps is %g; use 0 (%g frames/s) or a positive rate (at most %g "
        "frames/s are sent)",
        max_fps, kDefaultPreviewFps, kMaxPreviewFps));
  }
  if (request->max_frames() < 0) {
    return InvalidArgument(absl::StrCat("max_frames is ", request->max_frames(),
                                        "; use 0 (until cancelled) or more"));
  }
  if (rig_.camera() == nullptr) return Missing("camera", rig_.camera_error());
  if (absl::Status busy = CheckNoCapture(/*allow_waiting=*/true); !busy.ok()) {
    return ToGrpcStatus(busy);
  }
  const double fps =
      max_fps == 0 ? kDefaultPreviewFps : std::min(max_fps, kMaxPreviewFps);
  const absl::Duration period = absl::Seconds(1 / fps);
  const grpc::Status client_left(grpc::StatusCode::CANCELLED,
                                 "live view: the client went away");
  int64_t sent = 0;
  // The last message: why the stream ends.
  auto end = [&](std::string reason, int64_t job) {
    v1::PreviewMessage message;
    v1::PreviewEnded* ended = message.mutable_ended();
    ended->set_reason(std::move(reason));
    ended->set_capture_job_id(job);
    ended->set_frames(sent);
    writer->Write(message);
    return grpc::Status::OK;
  };
  for (absl::Time next = absl::InfinitePast();;) {
    if (request->max_frames() > 0 && sent >= request->max_frames()) {
      return end(absl::StrCat("sent the ", sent, " frames asked for"), 0);
    }
    // Until the next frame is due, wake for job events (a capture that
    // starts) and look whether the client is still there.
    for (absl::Time now = absl::Now(); now < next; now = absl::Now()) {
      const int64_t generation = engine_.event_generation();
      if (context->IsCancelled() || CaptureHoldingRigForPreview() != 0 ||
          engine_.stopping()) {
        break;
      }
      engine_.WaitForEvents(generation,
                            std::min(next, now + absl::Milliseconds(100)));
    }
    if (context->IsCancelled()) return client_left;
    if (engine_.stopping()) return end("the daemon is stopping", 0);
    if (const int64_t job = CaptureHoldingRigForPreview(); job != 0) {
      return end(absl::StrCat(DescribeJob(job), " started"), job);
    }
    absl::StatusOr<v1::PreviewFrame> frame = TakePreviewFrame();
    if (!frame.ok()) {
      // A capture took the rig meanwhile: that ends live view cleanly.
      if (const int64_t job = CaptureHoldingRigForPreview(); job != 0) {
        return end(absl::StrCat(DescribeJob(job), " started"), job);
      }
      return DeviceError(frame.status());
    }
    GuideCalibration(&*frame);
    const absl::Time now = absl::Now();
    frame->set_sequence(++sent);
    *frame->mutable_time() = TimestampOf(now);
    frame->set_fps_cap(fps);
    next = now + period;
    v1::PreviewMessage message;
    *message.mutable_frame() = *std::move(frame);
    if (!writer->Write(message)) return client_left;
  }
}

grpc::Status HardwareService::ProbeProjector(
    grpc::ServerContext* context, const v1::ProbeProjectorRequest* request,
    v1::ProjectorProbe* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  absl::StatusOr<jobs::ProbeOptions> options =
      jobs::ProbeOptionsFrom(request->options(), "options");
  if (!options.ok()) return ToGrpcStatus(options.status());
  if (rig_.camera() == nullptr) return Missing("camera", rig_.camera_error());
  if (rig_.projector() == nullptr) {
    return Missing("projector", rig_.projector_error());
  }
  absl::StatusOr<jobs::ProbeResult> probe;
  {
    absl::StatusOr<std::unique_lock<std::mutex>> lane = TakeLane(false);
    if (!lane.ok()) return ToGrpcStatus(lane.status());
    absl::StatusOr<hardware::CameraInfo> info = rig_.camera()->Info();
    if (!info.ok()) return DeviceError(info.status());
    if (info->max_exposure_s > 0 &&
        (options->exposure_s < info->min_exposure_s ||
         options->exposure_s > info->max_exposure_s)) {
      return InvalidArgument(absl::StrFormat(
          "options.exposure_s %g s is outside the camera's range [%g, %g] s",
          options->exposure_s, info->min_exposure_s, info->max_exposure_s));
    }
    probe = jobs::ProbeProjectorLatency(
        *rig_.camera(), *rig_.projector(), *options, [context] {
          return context->IsCancelled()
                     ? absl::CancelledError("the probe was cancelled")
                     : absl::OkStatus();
        });
    absl::MutexLock lock(&showing_mutex_);
    showing_ = "blank";
  }
  if (!probe.ok()) return DeviceError(probe.status());
  response->set_latency_s(absl::ToDoubleSeconds(probe->latency));
  response->set_step_s(absl::ToDoubleSeconds(probe->step));
  response->set_black_level(probe->black_level);
  response->set_white_level(probe->white_level);
  response->set_white_from(probe->white_from);
  for (const jobs::ProbeStep& step : probe->steps) {
    v1::ProjectorProbe::Frame* frame = response->add_frames();
    frame->set_delay_s(absl::ToDoubleSeconds(step.delay));
    frame->set_level(step.level);
    frame->set_white(step.white);
  }
  absl::StatusOr<double> refresh = rig_.projector()->RefreshHz();
  if (refresh.ok()) {
    response->set_refresh_hz(*refresh);
  } else {
    response->set_refresh_error(std::string(refresh.status().message()));
  }
  spdlog::info("projector probe: latency {} s in steps of {} s, refresh {}",
               response->latency_s(), response->step_s(),
               refresh.ok() ? absl::StrCat(*refresh, " Hz")
                            : std::string(refresh.status().message()));
  return grpc::Status::OK;
}

grpc::Status HardwareService::Lock(grpc::ServerContext* context,
                                   const v1::LockRequest* request,
                                   v1::RigLock* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  absl::StatusOr<jobs::RigLockState> state = lock_.Acquire(
      caller.principal.name, request->note(), absl::Seconds(request->ttl_s()));
  if (!state.ok()) return ToGrpcStatus(state.status());
  spdlog::info("rig locked by {} for {} s: {}", caller.principal.name,
               request->ttl_s(), request->note());
  ToProto(*state, response);
  return grpc::Status::OK;
}

grpc::Status HardwareService::Unlock(grpc::ServerContext* context,
                                     const v1::UnlockRequest* request,
                                     v1::RigLock* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (request->force() && caller.principal.role < Role::kAdmin) {
    return grpc::Status(
        grpc::StatusCode::PERMISSION_DENIED,
        absl::StrCat("force-unlocking needs role admin; ",
                     caller.principal.name, " has ",
                     RoleName(caller.principal.role),
                     " (without force, one can unlock one's own lock)"));
  }
  absl::StatusOr<jobs::RigLockState> released =
      lock_.Release(caller.principal.name, request->force());
  if (!released.ok()) return ToGrpcStatus(released.status());
  spdlog::info("rig unlocked by {}{} (was locked by {})", caller.principal.name,
               request->force() ? " (force)" : "", released->holder);
  response->set_locked(false);
  return grpc::Status::OK;
}

grpc::Status HardwareService::GetLock(grpc::ServerContext* context,
                                      const v1::GetLockRequest*,
                                      v1::RigLock* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (std::optional<jobs::RigLockState> state = lock_.Current()) {
    ToProto(*state, response);
  }
  return grpc::Status::OK;
}

}  // namespace hdrstereo::rpc
