// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/sim_world.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "hardware/sim/noise.h"
#include "processing/base/status_macros.h"
#include "processing/io/exif.h"

namespace hdrstereo::sim {

bool FaultFires(const FaultTrigger& trigger, int64_t call, uint64_t seed,
                uint64_t stream) {
  if (std::find(trigger.calls.begin(), trigger.calls.end(), call) !=
      trigger.calls.end()) {
    return true;
  }
  if (trigger.probability <= 0) return false;
  const double u = UniformFromBits(
      HashCombine(HashCombine(seed, stream), static_cast<uint64_t>(call)));
  return u < trigger.probability;
}

bool FaultWindowState::Call(bool can_begin) {
  ++calls_;
  if (can_begin && FaultFires(window_.begins, ++begin_calls_, seed_, stream_)) {
    holds_through_ = std::max(holds_through_, calls_ + window_.lasts - 1);
  }
  return calls_ <= holds_through_;
}

namespace {

// The hold fault: waits until a byte (or end of file) arrives on the FIFO at
// `path`. Opening it for reading also lets the test's open for writing
// return: that is how the test knows the camera is held.
absl::Status WaitForRelease(const std::string& path, int64_t call) {
  int fd = -1;
  do {
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("hold fault (call ", call, "): cannot open the FIFO ",
                     path, ": ", std::strerror(errno)));
  }
  char byte = 0;
  while (::read(fd, &byte, 1) < 0 && errno == EINTR) {
  }
  ::close(fd);
  return absl::OkStatus();
}

// One renderer for the scene as loaded, then one per board pose.
std::vector<std::unique_ptr<const Renderer>> RenderersFor(Scene scene) {
  std::vector<std::unique_ptr<const Renderer>> renderers;
  for (size_t k = 0; k < scene.calibration_board.poses.size(); ++k) {
    // ParseScene checked the board, so the pose exists.
    renderers.push_back(std::make_unique<const Renderer>(
        WithBoardPose(scene, static_cast<int>(k)).value()));
  }
  renderers.insert(renderers.begin(),
                   std::make_unique<const Renderer>(std::move(scene)));
  return renderers;
}

}  // namespace

SimWorld::SimWorld(Scene scene)
    : renderers_(RenderersFor(std::move(scene))),
      faults_(this->scene().camera_faults),
      low_battery_(faults_.low_battery, this->scene().seed, 7),
      projector_lost_(this->scene().projector_faults.lost, this->scene().seed,
                      8) {
  absent_since_start_ = !faults_.absent_until_file.empty();
  disconnected_ = absent_since_start_;
}

const Renderer& SimWorld::renderer() const {
  std::lock_guard<std::mutex> lock(mu_);
  return *renderers_[board_pose_ + 1];
}

absl::Status SimWorld::PlaceBoard(int pose) {
  const size_t poses = renderers_.size() - 1;
  if (poses == 0) {
    return absl::FailedPreconditionError(absl::StrCat(
        "scene \"", scene().name,
        "\" has no calibration_board poses: the board cannot move"));
  }
  if (pose < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("board pose ", pose, " is negative"));
  }
  std::lock_guard<std::mutex> lock(mu_);
  board_pose_ = static_cast<int>(pose % poses);
  return absl::OkStatus();
}

int SimWorld::board_pose() const {
  std::lock_guard<std::mutex> lock(mu_);
  return board_pose_;
}

void SimWorld::SetStagePosition(double mm) {
  std::lock_guard<std::mutex> lock(mu_);
  stage_mm_ = mm;
}

double SimWorld::StagePosition() const {
  std::lock_guard<std::mutex> lock(mu_);
  return stage_mm_;
}

absl::Status SimWorld::SetProjectorPattern(const cv::Mat& pattern) {
  if (!scene().projector.present) {
    return absl::FailedPreconditionError(
        absl::StrCat("scene \"", scene().name, "\" has no projector"));
  }
  const int depth = pattern.depth();
  if (!pattern.empty() &&
      ((pattern.channels() != 1 && pattern.channels() != 3) ||
       (depth != CV_8U && depth != CV_32F))) {
    return absl::InvalidArgumentError(
        "projector pattern must be 8-bit or float, with 1 or 3 channels");
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    GiveLocked(pattern.clone());
  }
  SleepModelled(timing().projector_settle_s);
  return absl::OkStatus();
}

void SimWorld::GiveLocked(cv::Mat pattern) {
  const double delay_s = scene().projector.latency_s * timing().scale;
  if (delay_s <= 0) {
    scheduled_.clear();
    pattern_ = std::move(pattern);
    return;
  }
  scheduled_.push_back(
      {absl::Now() + absl::Seconds(delay_s), std::move(pattern)});
}

const cv::Mat& SimWorld::ShowingLocked() const {
  const absl::Time now = absl::Now();
  while (!scheduled_.empty() && scheduled_.front().from <= now) {
    pattern_ = std::move(scheduled_.front().pattern);
    scheduled_.pop_front();
  }
  return pattern_;
}

void SimWorld::BlankProjector() {
  const ProjectorModel& p = scene().projector;
  std::lock_guard<std::mutex> lock(mu_);
  GiveLocked(cv::Mat::zeros(p.height, p.width, CV_8UC1));
}

void SimWorld::ProjectorOff() {
  std::lock_guard<std::mutex> lock(mu_);
  scheduled_.clear();
  pattern_.release();
}

cv::Mat SimWorld::ProjectorPattern() const {
  std::lock_guard<std::mutex> lock(mu_);
  return ShowingLocked();
}

absl::Status SimWorld::ProjectorCall(bool shows_pattern) {
  const ProjectorModel& p = scene().projector;
  std::lock_guard<std::mutex> lock(mu_);
  const bool lost = projector_lost_.Call(shows_pattern);
  if (lost) {
    scheduled_.clear();
    pattern_.release();
  } else if (projector_out_) {
    pattern_ = cv::Mat::zeros(p.height, p.width, CV_8UC1);
  }
  projector_out_ = lost;
  if (lost) {
    return absl::UnavailableError(
        "projector lost (simulated fault: no signal; it comes back by "
        "itself)");
  }
  return absl::OkStatus();
}

int SimWorld::ReadBattery() {
  std::lock_guard<std::mutex> lock(mu_);
  return low_battery_.Call() ? faults_.low_battery_percent : 100;
}

RadianceFrame SimWorld::RenderRadiance() const {
  double stage = 0;
  cv::Mat pattern;
  {
    std::lock_guard<std::mutex> lock(mu_);
    stage = stage_mm_;
    pattern = ShowingLocked();
  }
  return renderer().Render(CameraView(scene(), stage), pattern);
}

cv::Mat SimWorld::RenderExposure(const ExposureSettings& settings, int bits) {
  int64_t index = 0;
  double stage = 0;
  cv::Mat pattern;
  {
    std::lock_guard<std::mutex> lock(mu_);
    index = frame_index_++;
    stage = stage_mm_;
    pattern = ShowingLocked();
  }
  return RenderFrame(renderer(), CameraView(scene(), stage), pattern, settings,
                     HashCombine(scene().seed, static_cast<uint64_t>(index)),
                     bits);
}

cv::Mat RenderFrame(const Renderer& renderer, const View& view,
                    const cv::Mat& projector_pattern,
                    const ExposureSettings& settings, uint64_t noise_seed,
                    int bits) {
  const RadianceFrame frame = renderer.Render(view, projector_pattern);
  const cv::Mat electrons = ExposeSensor(
      frame.radiance, renderer.scene().sensor, settings, noise_seed);
  return Digitize(electrons, renderer.scene().sensor, bits);
}

View PreviewView(const Scene& scene, double stage_mm) {
  View view = CameraView(scene, stage_mm);
  CameraIntrinsics& c = view.intrinsics;
  if (c.width <= kPreviewMaxWidth) return view;
  // Pixel centres scale about the image corner: (u + 0.5) * k - 0.5.
  const double k = static_cast<double>(kPreviewMaxWidth) / c.width;
  c.width = kPreviewMaxWidth;
  c.height = std::max(1, static_cast<int>(std::lround(c.height * k)));
  c.fx *= k;
  c.fy *= k;
  c.cx = (c.cx + 0.5) * k - 0.5;
  c.cy = (c.cy + 0.5) * k - 0.5;
  return view;
}

uint64_t PreviewNoiseSeed(const Scene& scene, int64_t preview_index) {
  // A stream of its own: previews never repeat a capture's noise.
  constexpr uint64_t kPreviewStream = 0x9e5f'11f3'a2c4'6b01;
  return HashCombine(HashCombine(scene.seed, kPreviewStream),
                     static_cast<uint64_t>(preview_index));
}

absl::StatusOr<SimCapture> SimWorld::Preview(const ExposureSettings& settings) {
  if (!(settings.exposure_s > 0) || !(settings.iso > 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("exposure (", settings.exposure_s, " s) and ISO (",
                     settings.iso, ") must be > 0"));
  }
  SimCapture preview;
  cv::Mat pattern;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (disconnected_) {
      return absl::FailedPreconditionError(
          "camera disconnected (simulated); reconnect first");
    }
    preview.frame_index = preview_index_++;
    preview.stage_mm = stage_mm_;
    pattern = ShowingLocked();
  }
  preview.format = ImageFormat::kJpeg;
  preview.settings = settings;
  preview.image =
      RenderFrame(renderer(), PreviewView(scene(), preview.stage_mm), pattern,
                  settings, PreviewNoiseSeed(scene(), preview.frame_index));
  ASSIGN_OR_RETURN(preview.bytes, EncodeImage(preview.image, preview.format));
  return preview;
}

absl::StatusOr<SimCapture> SimWorld::Render(const ExposureSettings& settings,
                                            ImageFormat format, double stage,
                                            const cv::Mat& pattern,
                                            bool other_depth) {
  int64_t index = 0;
  absl::Time camera_time;
  {
    std::lock_guard<std::mutex> lock(mu_);
    index = frame_index_++;
    camera_time =
        std::max(absl::FromUnixMillis(absl::ToUnixMillis(absl::Now())),
                 last_camera_time_ + absl::Milliseconds(1));
    last_camera_time_ = camera_time;
  }
  SimCapture capture;
  capture.format = format;
  capture.settings = settings;
  capture.stage_mm = stage;
  capture.frame_index = index;
  capture.camera_time = camera_time;
  RadianceFrame frame = renderer().Render(CameraView(scene(), stage), pattern);
  cv::Mat electrons =
      ExposeSensor(frame.radiance, scene().sensor, settings,
                   HashCombine(scene().seed, static_cast<uint64_t>(index)));
  absl::StatusOr<std::string> bytes;
  switch (format) {
    case ImageFormat::kPng:
    case ImageFormat::kJpeg:
      capture.image =
          Digitize(electrons, scene().sensor,
                   other_depth && format == ImageFormat::kPng ? 16 : 8);
      bytes = EncodeImage(capture.image, format);
      break;
    case ImageFormat::kTiff16:
      capture.image = Digitize(electrons, scene().sensor, other_depth ? 8 : 16);
      bytes = EncodeImage(capture.image, format);
      break;
    case ImageFormat::kDng:
      capture.image = MosaicBayer(electrons, scene().sensor);
      bytes = EncodeDng(capture.image, scene().sensor, settings);
      break;
  }
  if (!bytes.ok()) return bytes.status();
  capture.bytes = *std::move(bytes);
  if (format == ImageFormat::kPng || format == ImageFormat::kJpeg) {
    io::ExifInfo exif;
    exif.exposure_s = settings.exposure_s;
    exif.iso = settings.iso;
    exif.aperture = settings.aperture_f;
    exif.camera = "hdrstereo sim";
    exif.date_time_original =
        absl::FormatTime("%Y:%m:%d %H:%M:%S", camera_time, absl::UTCTimeZone());
    exif.subsec_time_original = absl::StrFormat(
        "%03d", static_cast<int>(absl::ToUnixMillis(camera_time) % 1000));
    ASSIGN_OR_RETURN(std::string stamped,
                     io::EmbedExif(capture.bytes, io::EncodeExifTiff(exif)));
    capture.bytes = std::move(stamped);
  }
  std::string extension(ImageFormatName(format));
  if (format == ImageFormat::kJpeg) extension = "jpg";
  capture.file_name = absl::StrFormat("SIM_%04d.%s", (index % 9999) + 1,
                                      absl::AsciiStrToUpper(extension));
  return capture;
}

absl::StatusOr<int> SimWorld::PrepareCaptureGroup() {
  std::lock_guard<std::mutex> lock(mu_);
  if (disconnected_) {
    return absl::FailedPreconditionError(
        "camera disconnected (simulated); reconnect first");
  }
  target_on_card_ = false;
  const int drained = held_.has_value() ? 1 : 0;
  held_.reset();
  return drained;
}

std::optional<SimCapture> SimWorld::TakePendingFile() {
  std::lock_guard<std::mutex> lock(mu_);
  std::optional<SimCapture> pending = std::move(held_);
  held_.reset();
  return pending;
}

absl::StatusOr<SimCapture> SimWorld::Capture(
    const ExposureSettings& settings, ImageFormat format,
    const std::function<void()>& accepted) {
  if (!(settings.exposure_s > 0) || !(settings.iso > 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("exposure (", settings.exposure_s, " s) and ISO (",
                     settings.iso, ") must be > 0"));
  }
  int64_t call = 0;
  double stage = 0;
  cv::Mat pattern;
  CameraFaults faults;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (disconnected_) {
      return absl::FailedPreconditionError(
          "camera disconnected (simulated); reconnect first");
    }
    call = ++capture_calls_;
    faults = faults_;
    stage = stage_mm_;
    pattern = ShowingLocked();
  }
  const uint64_t seed = scene().seed;
  const double capture_s = timing().CaptureSeconds(settings.exposure_s);
  if (call <= faults.busy_first_calls) {
    return absl::UnavailableError(
        absl::StrCat("camera busy (simulated fault, call ", call, ")"));
  }
  if (accepted) accepted();
  if (FaultFires(faults.hold, call, seed, 7)) {
    RETURN_IF_ERROR(WaitForRelease(faults.hold_fifo, call));
  }
  if (FaultFires(faults.timeout, call, seed, 1)) {
    SleepModelled(capture_s);
    return absl::DeadlineExceededError(
        absl::StrCat("camera timed out (simulated fault, call ", call, ")"));
  }
  if (FaultFires(faults.disconnect, call, seed, 2)) {
    SleepModelled(settings.exposure_s + timing().readout_s +
                  timing().transfer_s / 2);
    std::lock_guard<std::mutex> lock(mu_);
    disconnected_ = true;
    failed_reopens_ = 0;
    return absl::AbortedError(absl::StrCat(
        "camera disconnected during transfer (simulated fault, call ", call,
        ")"));
  }
  ExposureSettings used = settings;
  if (FaultFires(faults.wrong_exposure, call, seed, 4)) used.exposure_s *= 2;
  const bool other_depth = FaultFires(faults.wrong_depth, call, seed, 8);
  ASSIGN_OR_RETURN(SimCapture fresh,
                   Render(used, format, stage, pattern, other_depth));
  SimCapture capture = std::move(fresh);
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (FaultFires(faults.card_target, call, seed, 5)) target_on_card_ = true;
    capture.on_card = target_on_card_;
    const bool stale = FaultFires(faults.previous_file, call, seed, 6) &&
                       last_delivered_.has_value();
    if (stale || held_.has_value()) {
      // The camera answers with an older file and keeps the new one.
      SimCapture older = stale ? *last_delivered_ : *std::move(held_);
      held_ = std::move(capture);
      capture = std::move(older);
    }
    last_delivered_ = capture;
  }
  if (FaultFires(faults.corrupt, call, seed, 3) && capture.bytes.size() > 64) {
    // Flip bytes after the header so the damage is in the pixel data.
    uint64_t h = HashCombine(seed, 1000 + static_cast<uint64_t>(call));
    const size_t span = capture.bytes.size() - 64;
    for (int i = 0; i < 32; ++i) {
      h = SplitMix64(h);
      capture.bytes[64 + h % span] ^= static_cast<char>(0x5a);
    }
    capture.corrupted = true;
  }
  SleepModelled(capture_s);
  return capture;
}

void SimWorld::ReconnectCamera() {
  std::lock_guard<std::mutex> lock(mu_);
  disconnected_ = false;
  failed_reopens_ = 0;
  absent_since_start_ = false;
}

absl::Status SimWorld::ReopenCamera() {
  std::lock_guard<std::mutex> lock(mu_);
  if (!disconnected_) return absl::OkStatus();
  if (absent_since_start_) {
    std::error_code ec;
    if (!std::filesystem::exists(faults_.absent_until_file, ec)) {
      return absl::UnavailableError(
          absl::StrCat("no camera found (simulated: not plugged in until ",
                       faults_.absent_until_file, " exists)"));
    }
    absent_since_start_ = false;
    disconnected_ = false;
    return absl::OkStatus();
  }
  const int fails = faults_.disconnect_failed_reopens;
  if (fails < 0 || failed_reopens_ < fails) {
    ++failed_reopens_;
    return absl::UnavailableError(
        absl::StrCat("no camera found (simulated disconnect: reopen attempt ",
                     failed_reopens_,
                     fails < 0 ? "; the camera does not come back"
                               : absl::StrCat(" of ", fails, " that fail"),
                     ")"));
  }
  disconnected_ = false;
  failed_reopens_ = 0;
  return absl::OkStatus();
}

bool SimWorld::camera_connected() const {
  std::lock_guard<std::mutex> lock(mu_);
  return !disconnected_;
}

int64_t SimWorld::capture_calls() const {
  std::lock_guard<std::mutex> lock(mu_);
  return capture_calls_;
}

absl::StatusOr<StereoTruth> SimWorld::Truth(double left_mm,
                                            double baseline_mm) const {
  return ComputeStereoTruth(renderer(), left_mm, baseline_mm,
                            ProjectorPattern());
}

void SimWorld::SleepModelled(double seconds) const {
  const double s = seconds * timing().scale;
  if (s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(s));
}

}  // namespace hdrstereo::sim
