// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/sim_session.h"

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hardware/sim/truth.h"
#include "processing/base/status_macros.h"
#include "processing/io/capture_layout.h"
#include "processing/io/hdr_formats.h"
#include "processing/structured_light/gray_code.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::testing {
namespace fs = std::filesystem;

namespace {

absl::Status Save(const fs::path& path, const cv::Mat& image) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  return io::WritePng(path, image);
}

}  // namespace

absl::Status RenderSimSession(const fs::path& dir,
                              const SimSessionOptions& options) {
  absl::StatusOr<sim::Scene> scene = sim::LoadBundledScene(options.scene);
  if (!scene.ok()) return scene.status();
  sim::ScaleCamera(*scene, options.width);
  scene->projector.width = options.projector_width;
  scene->projector.height = options.projector_height;
  scene->timing.scale = 0;
  sim::SimWorld world(*scene);
  // Capture 1: bracketed stereo with its truth; capture 2: structured light.
  auto frame = [&](int64_t capture, int view, const io::FrameKey& key) {
    return dir / (io::FrameStem(capture, io::ViewName(view), key) + ".png");
  };
  io::FrameKey key;
  world.BlankProjector();
  world.SetStagePosition(0);
  key.role = io::FrameRole::kAmbient;
  key.exposure_s = options.exposures[options.exposures.size() / 2];
  RETURN_IF_ERROR(
      Save(frame(1, 0, key), world.RenderExposure({key.exposure_s, 100}, 8)));
  key.role = io::FrameRole::kStereo;
  for (int v = 0; v < 2; ++v) {
    world.SetStagePosition(v * options.baseline_mm);
    for (double e : options.exposures) {
      key.exposure_s = e;
      RETURN_IF_ERROR(
          Save(frame(1, v, key), world.RenderExposure({e, 100}, 8)));
    }
  }
  if (options.truth) {
    ASSIGN_OR_RETURN(const sim::StereoTruth truth,
                     world.Truth(0, options.baseline_mm));
    RETURN_IF_ERROR(sim::WriteStereoTruth(truth, dir / io::TruthDir(1)));
  }
  if (options.structured_light) {
    const cv::Size psize(options.projector_width, options.projector_height);
    key.role = io::FrameRole::kStructuredLight;
    for (int v = 0; v < 2; ++v) {
      world.SetStagePosition(v * options.baseline_mm);
      for (double e : options.sl_exposures) {
        key.exposure_s = e;
        for (const structured_light::Pattern& p :
             structured_light::AllPatterns(psize)) {
          ASSIGN_OR_RETURN(const cv::Mat pattern,
                           structured_light::Render(p, psize));
          RETURN_IF_ERROR(world.SetProjectorPattern(pattern));
          key.pattern = p.Id();
          key.inverse = p.inverse;
          RETURN_IF_ERROR(
              Save(frame(2, v, key), world.RenderExposure({e, 100}, 8)));
        }
      }
    }
  }
  return absl::OkStatus();
}

absl::Status CopyCachedSimSession(const fs::path& dir) {
  // Function-local statics: rendered once, removed at exit.
  static const TempDir cache;
  static const bool rendered = RenderSimSession(cache / "session").ok();
  if (!rendered) {
    return absl::InternalError("rendering the simulated session failed");
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  fs::copy(cache / "session", dir, fs::copy_options::recursive, ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat("copying the simulated session: ", ec.message()));
  }
  return absl::OkStatus();
}

}  // namespace hdrstereo::testing
