// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-sim: render frames and ground truth from a simulated scene, or
// run the emulated Zaber stage on a pseudo-terminal.
//
//   hdrstereo-sim scenes
//   hdrstereo-sim render --scene lab-lamp --stage-mm 0 --exposure-s 0.008
//       [--iso 100] [--format png|jpeg|tiff|dng] [--pattern P.png]
//       [--seed N] [--truth --baseline-mm 150] --out DIR
//   hdrstereo-sim stage [--scene lab-lamp]   (prints the device path, runs
//                                             until interrupted)
//   hdrstereo-sim camera --ptpip 127.0.0.1:PORT [--scene lab-lamp]
//       [--format png|jpeg|tiff|dng] [--stage-mm 0]
//       (a PTP/IP camera; PORT 0 = a free one; prints libgphoto2's port
//       string, e.g. ptpip:127.0.0.1:40123:40123, runs until interrupted)
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <system_error>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "hardware/sim/camera_model.h"
#include "hardware/sim/ptpip_camera.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hardware/sim/stage_emulator.h"
#include "hardware/sim/truth.h"
#include "processing/io/atomic_file.h"
#include "processing/io/middlebury.h"

namespace hdrstereo::sim {
namespace {

constexpr int kExitOk = 0;
constexpr int kExitError = 1;
constexpr int kExitUsage = 2;

struct RenderOptions {
  std::string scene = "lab-lamp";
  double stage_mm = 0;
  double exposure_s = 1.0 / 125;
  double iso = 100;
  std::string format = "png";
  std::string pattern;
  int64_t seed = -1;
  bool truth = false;
  double baseline_mm = 150;
  std::string out;
};

int Fail(const absl::Status& status) {
  std::cerr << "hdrstereo-sim: " << status.message() << "\n";
  return status.code() == absl::StatusCode::kInvalidArgument ||
                 status.code() == absl::StatusCode::kNotFound
             ? kExitUsage
             : kExitError;
}

absl::Status CheckStagePosition(double stage_mm, const Scene& scene) {
  if (stage_mm >= 0 && stage_mm <= scene.rig.travel_mm) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(
      absl::StrFormat("--stage-mm %.3f is outside the travel 0..%.3f mm",
                      stage_mm, scene.rig.travel_mm));
}

int Render(const RenderOptions& o) {
  absl::StatusOr<Scene> scene = LoadScene(o.scene);
  if (!scene.ok()) return Fail(scene.status());
  if (o.seed >= 0) scene->seed = static_cast<uint64_t>(o.seed);
  absl::StatusOr<ImageFormat> format = ParseImageFormat(o.format);
  if (!format.ok()) return Fail(format.status());
  if (absl::Status s = CheckStagePosition(o.stage_mm, *scene); !s.ok()) {
    return Fail(s);
  }
  scene->timing.scale = 0;  // the tool never waits for modelled time
  SimWorld world(*std::move(scene));
  world.SetStagePosition(o.stage_mm);
  if (!o.pattern.empty()) {
    cv::Mat pattern = cv::imread(o.pattern, cv::IMREAD_UNCHANGED);
    if (pattern.empty()) {
      return Fail(absl::InvalidArgumentError(
          absl::StrCat("cannot read --pattern ", o.pattern)));
    }
    if (absl::Status s = world.SetProjectorPattern(pattern); !s.ok()) {
      return Fail(s);
    }
  }
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) {
    return Fail(absl::InternalError(
        absl::StrCat("cannot create ", o.out, ": ", ec.message())));
  }
  absl::StatusOr<SimCapture> capture =
      world.Capture(ExposureSettings{o.exposure_s, o.iso}, *format);
  if (!capture.ok()) return Fail(capture.status());
  const std::string ext = *format == ImageFormat::kJpeg     ? "jpg"
                          : *format == ImageFormat::kTiff16 ? "tiff"
                          : *format == ImageFormat::kDng    ? "dng"
                                                            : "png";
  const std::filesystem::path image_path =
      std::filesystem::path(o.out) / absl::StrCat("frame.", ext);
  if (absl::Status s = io::WriteFileAtomically(image_path, capture->bytes);
      !s.ok()) {
    return Fail(s);
  }
  std::cout << image_path.string() << "\n";
  if (o.truth) {
    absl::StatusOr<StereoTruth> truth = world.Truth(o.stage_mm, o.baseline_mm);
    if (!truth.ok()) return Fail(truth.status());
    if (absl::Status s = WriteStereoTruth(*truth, o.out); !s.ok()) {
      return Fail(s);
    }
    std::cout << (std::filesystem::path(o.out) / io::kCalibFile).string()
              << "\n";
  }
  return kExitOk;
}

volatile sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

int RunStage(const std::string& scene_name) {
  absl::StatusOr<Scene> scene = LoadScene(scene_name);
  if (!scene.ok()) return Fail(scene.status());
  SimWorld world(*scene);
  absl::StatusOr<std::unique_ptr<StageEmulator>> stage = StageEmulator::Start(
      StageEmulatorOptions::FromScene(world.scene()), &world);
  if (!stage.ok()) return Fail(stage.status());
  std::cout << (*stage)->device_path() << std::endl;
  signal(SIGINT, OnSignal);
  signal(SIGTERM, OnSignal);
  while (!g_stop) usleep(50000);
  return kExitOk;
}

struct CameraOptions {
  std::string ptpip;
  std::string scene = "lab-lamp";
  std::string format = "png";
  double stage_mm = 0;
};

int RunCamera(const CameraOptions& o) {
  const size_t colon = o.ptpip.rfind(':');
  int port = -1;
  if (colon == std::string::npos ||
      !absl::SimpleAtoi(o.ptpip.substr(colon + 1), &port)) {
    return Fail(absl::InvalidArgumentError(
        absl::StrCat("--ptpip must be ADDRESS:PORT (e.g. 127.0.0.1:0), not \"",
                     o.ptpip, "\"")));
  }
  absl::StatusOr<Scene> scene = LoadScene(o.scene);
  if (!scene.ok()) return Fail(scene.status());
  absl::StatusOr<ImageFormat> format = ParseImageFormat(o.format);
  if (!format.ok()) return Fail(format.status());
  if (absl::Status s = CheckStagePosition(o.stage_mm, *scene); !s.ok()) {
    return Fail(s);
  }
  SimWorld world(*std::move(scene));
  world.SetStagePosition(o.stage_mm);
  PtpIpCameraOptions options;
  options.address = o.ptpip.substr(0, colon);
  options.port = port;
  options.format = *format;
  // Before the port is printed: whoever reads it may stop us at once.
  signal(SIGINT, OnSignal);
  signal(SIGTERM, OnSignal);
  absl::StatusOr<std::unique_ptr<PtpIpCamera>> camera =
      PtpIpCamera::Start(world, options);
  if (!camera.ok()) return Fail(camera.status());
  std::cout << (*camera)->gphoto2_port() << std::endl;
  while (!g_stop) usleep(50000);
  return kExitOk;
}

}  // namespace
}  // namespace hdrstereo::sim

int main(int argc, char** argv) {
  using namespace hdrstereo::sim;
  CLI::App app{"hdrstereo-sim: simulated HDR stereo lab", "hdrstereo-sim"};
  app.require_subcommand(1);

  CLI::App* scenes = app.add_subcommand("scenes", "List the bundled scenes");

  RenderOptions r;
  CLI::App* render = app.add_subcommand(
      "render", "Render one frame (and optionally ground truth)");
  render->add_option("--scene", r.scene, "Bundled scene name or JSON file")
      ->capture_default_str();
  render->add_option("--stage-mm", r.stage_mm, "Stage position (mm)")
      ->capture_default_str();
  render->add_option("--exposure-s", r.exposure_s, "Exposure time (s)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  render->add_option("--iso", r.iso, "ISO")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  render->add_option("--format", r.format, "png, jpeg, tiff (16-bit) or dng")
      ->capture_default_str();
  render->add_option("--pattern", r.pattern, "Projector pattern image");
  render->add_option("--seed", r.seed, "Noise seed (default: the scene's)");
  render->add_flag("--truth", r.truth,
                   "Also write radiance, depth, disparity and masks");
  render
      ->add_option("--baseline-mm", r.baseline_mm,
                   "Baseline for --truth (right view at stage + baseline)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  render->add_option("--out", r.out, "Output folder")->required();

  std::string stage_scene = "lab-lamp";
  CLI::App* stage = app.add_subcommand(
      "stage", "Run the Zaber stage emulator; prints its device path");
  stage->add_option("--scene", stage_scene, "Scene for travel/timing/faults")
      ->capture_default_str();

  CameraOptions c;
  CLI::App* camera = app.add_subcommand(
      "camera",
      "Run the simulated camera as a PTP/IP camera (model \"PTP/IP Camera\" "
      "in libgphoto2); prints its gphoto2 port");
  camera
      ->add_option("--ptpip", c.ptpip,
                   "IPv4 address and port to listen on (port 0: a free one)")
      ->required();
  camera->add_option("--scene", c.scene, "Bundled scene name or JSON file")
      ->capture_default_str();
  camera->add_option("--format", c.format, "png, jpeg, tiff (16-bit) or dng")
      ->capture_default_str();
  camera->add_option("--stage-mm", c.stage_mm, "Where the camera stands (mm)")
      ->capture_default_str();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }
  if (scenes->parsed()) {
    for (const std::string& name : BundledSceneNames()) {
      std::cout << name << "\n";
    }
    return 0;
  }
  if (render->parsed()) return Render(r);
  if (stage->parsed()) return RunStage(stage_scene);
  if (camera->parsed()) return RunCamera(c);
  return 2;
}
