// SPDX-License-Identifier: GPL-3.0-or-later
//
// SimWorld: one simulated lab. It holds the scene, the stage position and
// the projector's current pattern, renders what the camera sees, and knows
// the exact truth. Every method is thread-safe: a stage emulator thread can
// move the stage while a capture job renders.
//
// Adapters for the hardware interfaces map:
//   Camera::Configure/Capture -> SimWorld::Capture(ExposureSettings, format)
//   Camera::Preview           -> SimWorld::Preview(ExposureSettings)
//   Camera::Info              -> ReadBattery()
//   Stage                     -> StageEmulator (a Zaber device on a pty),
//                                or SetStagePosition() directly
//   Projector::Show/Blank     -> ProjectorCall(), then SetProjectorPattern()
//                                / BlankProjector()
//   Projector::Check          -> ProjectorCall()
#ifndef HDRSTEREO_HARDWARE_SIM_SIM_WORLD_H_
#define HDRSTEREO_HARDWARE_SIM_SIM_WORLD_H_

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "hardware/sim/camera_model.h"
#include "hardware/sim/render.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/truth.h"

namespace hdrstereo::sim {

// Which calls a FaultWindow holds on, call by call (seeded, reproducible).
// Not thread-safe: its owner locks.
class FaultWindowState {
 public:
  FaultWindowState(const FaultWindow& window, uint64_t seed, uint64_t stream)
      : window_(window), seed_(seed), stream_(stream) {}
  // One more call; `can_begin`: whether it is one of the calls that
  // window.begins counts. True when the fault holds on it.
  bool Call(bool can_begin = true);

 private:
  FaultWindow window_;
  uint64_t seed_;
  uint64_t stream_;
  int64_t begin_calls_ = 0;
  int64_t calls_ = 0;
  int64_t holds_through_ = 0;  // the last call it holds on
};

// Live view renders the camera's field of view at most this many pixels
// wide (the height keeps the aspect ratio).
inline constexpr int kPreviewMaxWidth = 480;

// The camera's view for live view: CameraView(scene, stage_mm) with the
// intrinsics scaled to at most kPreviewMaxWidth pixels wide (rounded
// height), the same field of view.
View PreviewView(const Scene& scene, double stage_mm);
// The noise realisation of the n-th live-view frame (from 0) of a world.
uint64_t PreviewNoiseSeed(const Scene& scene, int64_t preview_index);

struct SimCapture {
  std::string bytes;  // the encoded file, as a camera would deliver it
  ImageFormat format = ImageFormat::kPng;
  cv::Mat image;  // the decoded pixels (BGR, or the Bayer mosaic for DNG)
  ExposureSettings settings;
  double stage_mm = 0;
  int64_t frame_index = 0;  // selects the noise realisation
  bool corrupted = false;   // a corrupt-bytes fault hit this file
  // As a camera names and stamps its files: "SIM_0001.PNG" (numbered by
  // exposure), the camera clock (strictly increasing, in milliseconds) in
  // EXIF DateTimeOriginal + SubSecTimeOriginal of PNG and JPEG files.
  std::string file_name;
  absl::Time camera_time;
  bool on_card = false;  // the card-target fault had switched the target
};

class SimWorld {
 public:
  explicit SimWorld(Scene scene);
  SimWorld(const SimWorld&) = delete;
  SimWorld& operator=(const SimWorld&) = delete;

  // The scene as loaded (the calibration board where the file puts it).
  const Scene& scene() const { return renderers_.front()->scene(); }
  // The renderer of the world as it is now: the board in the pose
  // PlaceBoard last placed it in. The reference stays valid for the
  // world's life.
  const Renderer& renderer() const;
  const TimingModel& timing() const { return scene().timing; }

  // The simulated operator places the calibration board in pose `pose`
  // (0-based; scene.calibration_board.poses, taken modulo their number):
  // renders, captures, previews and the truth see it there from now on.
  // FAILED_PRECONDITION when the scene has no board poses, INVALID_ARGUMENT
  // for a negative pose.
  absl::Status PlaceBoard(int pose);
  // The pose the board is in (-1: where the scene file puts it).
  int board_pose() const;

  // Stage position in mm along the stage axis (not range-checked here: the
  // stage emulator enforces travel limits).
  void SetStagePosition(double mm);
  double StagePosition() const;

  // What the projector is given (see Renderer::Render for accepted types);
  // then sleeps timing.projector_settle_s * timing.scale. It shows from
  // projector.latency_s * timing.scale after the call on; until then the
  // pattern given before it shows (renders, captures and the truth all see
  // the pattern showing at their time). INVALID_ARGUMENT for an
  // unsupported type, FAILED_PRECONDITION for a scene without projector.
  absl::Status SetProjectorPattern(const cv::Mat& pattern);
  // An all-black pattern (only the black level shines), with the same
  // latency.
  void BlankProjector();
  void ProjectorOff();  // no light at all, at once
  // The pattern showing now.
  cv::Mat ProjectorPattern() const;
  // Every call to the projector (SimProjector: Show and Blank with
  // `shows_pattern`, Check without) is counted here first: OK, or
  // UNAVAILABLE "projector lost" while a projector_faults.lost window
  // holds. While lost nothing is projected; the first call after it finds
  // the projector showing black.
  absl::Status ProjectorCall(bool shows_pattern);

  // The battery level the camera reports (CameraInfo::battery_percent):
  // 100, or camera_faults.low_battery_percent while a low_battery window
  // holds. Each call is one reading.
  int ReadBattery();

  // Noise-free radiance, depth and ids at the current stage position.
  RadianceFrame RenderRadiance() const;
  // One frame at the current stage position: bits 8 -> CV_8UC3 (response
  // curve), 16 -> CV_16UC3 (linear). Each call uses the next noise
  // realisation (frame index), so the sequence is reproducible per seed.
  cv::Mat RenderExposure(const ExposureSettings& settings, int bits = 8);

  // A full camera capture: applies camera faults, renders, encodes, and
  // sleeps for the modelled capture time times timing.scale. Errors:
  //   UNAVAILABLE "camera busy" (faults.busy_first_calls; retry later),
  //   DEADLINE_EXCEEDED (timeout fault),
  //   ABORTED (disconnected mid-transfer), then FAILED_PRECONDITION on every
  //   call until the camera is reopened (ReopenCamera) or plugged in again
  //   (ReconnectCamera).
  // A corrupt fault returns OK with damaged bytes (corrupted = true).
  // `accepted`, when given, is called once the camera takes the trigger
  // (not busy, not disconnected), before it exposes: a network camera
  // answers the trigger then and announces the file later.
  absl::StatusOr<SimCapture> Capture(
      const ExposureSettings& settings, ImageFormat format,
      const std::function<void()>& accepted = nullptr);
  // A live-view frame: the scene at the current stage position lit by the
  // pattern showing now, seen through PreviewView, exposed with `settings`
  // and noise PreviewNoiseSeed(scene, n) for the n-th preview (the world's
  // previews counted from 0; captures do not count), 8-bit as
  // RenderFrame, JPEG-encoded. Camera faults do not apply (they count
  // captures), except that a disconnected camera gives FAILED_PRECONDITION.
  absl::StatusOr<SimCapture> Preview(const ExposureSettings& settings);
  // Plugs the camera in again, whatever the fault says.
  void ReconnectCamera();
  // What a driver's reopen finds: OK when the camera is connected or comes
  // back now; after a disconnect the first
  // faults.disconnect_failed_reopens attempts fail with UNAVAILABLE "no
  // camera found", all of them when that is -1. A camera absent from the
  // start (faults.absent_until_file) is found once that file exists.
  absl::Status ReopenCamera();
  bool camera_connected() const;
  // What a capture group starts with: the capture target back to RAM, and
  // the files a previous-file fault left pending discarded. Returns how
  // many were discarded; FAILED_PRECONDITION while disconnected.
  absl::StatusOr<int> PrepareCaptureGroup();
  // The file a previous-file fault keeps pending, taken out of the world:
  // a network camera (ptpip_camera.h) announces it as a file of its own,
  // which the driver's drain deletes. nullopt when none is pending.
  std::optional<SimCapture> TakePendingFile();
  int64_t capture_calls() const;

  // Exact truth for views at left_mm and left_mm + baseline_mm, lit by the
  // current projector pattern.
  absl::StatusOr<StereoTruth> Truth(double left_mm, double baseline_mm) const;

  // Sleeps seconds * timing.scale (no-op for scale 0).
  void SleepModelled(double seconds) const;

 private:
  // Renders, encodes and names one exposure; `other_depth`: a PNG or TIFF
  // file of the other bit depth than its format's (the wrong_depth fault).
  absl::StatusOr<SimCapture> Render(const ExposureSettings& settings,
                                    ImageFormat format, double stage,
                                    const cv::Mat& pattern,
                                    bool other_depth = false);
  // Gives the projector `pattern` (see SetProjectorPattern); mu_ held.
  void GiveLocked(cv::Mat pattern);
  // The pattern showing now: scheduled patterns that are due replace
  // pattern_. mu_ held.
  const cv::Mat& ShowingLocked() const;

  // [0]: the scene as loaded; [1 + k]: the board in pose k. Built once,
  // so a reference to any of them stays valid.
  std::vector<std::unique_ptr<const Renderer>> renderers_;
  mutable std::mutex mu_;
  int board_pose_ = -1;  // renderers_[board_pose_ + 1] is current
  double stage_mm_ = 0;
  mutable cv::Mat pattern_;  // showing (as of the last ShowingLocked)
  // Patterns given but not showing yet (projector latency), by time.
  struct Scheduled {
    absl::Time from;
    cv::Mat pattern;
  };
  mutable std::deque<Scheduled> scheduled_;
  int64_t frame_index_ = 0;
  int64_t preview_index_ = 0;
  int64_t capture_calls_ = 0;
  bool disconnected_ = false;
  int failed_reopens_ = 0;  // reopen attempts failed since the disconnect
  bool absent_since_start_ = false;  // faults.absent_until_file, not found
  CameraFaults faults_;
  bool target_on_card_ = false;
  absl::Time last_camera_time_ = absl::UnixEpoch();
  std::optional<SimCapture> last_delivered_;  // for the previous-file fault
  std::optional<SimCapture> held_;            // pending in the camera
  FaultWindowState low_battery_;
  FaultWindowState projector_lost_;
  bool projector_out_ = false;  // a lost window holds on the last call
};

// One camera frame without a SimWorld: render `view` lit by
// `projector_pattern`, expose with noise realisation `noise_seed`, digitise
// to `bits` (8 or 16). SimWorld::RenderExposure is this at the current stage
// position with seed HashCombine(scene.seed, frame index).
cv::Mat RenderFrame(const Renderer& renderer, const View& view,
                    const cv::Mat& projector_pattern,
                    const ExposureSettings& settings, uint64_t noise_seed,
                    int bits = 8);

// Whether `trigger` fires on 1-based call `call` (seeded, reproducible).
bool FaultFires(const FaultTrigger& trigger, int64_t call, uint64_t seed,
                uint64_t stream);

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_SIM_WORLD_H_
