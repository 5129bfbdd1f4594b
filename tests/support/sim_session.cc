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
#include "processing/io/hdr_formats.h"
#include "processing/structured_light/capture_io.h"
#include "processing/structured_light/decode.h"
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
  sim::CameraIntrinsics& c = scene->camera;
  const double k = static_cast<double>(options.width) / c.width;
  c.height = static_cast<int>(std::lround(c.height * k));
  c.width = options.width;
  c.fx *= k;
  c.fy *= k;
  c.cx = (c.width - 1) / 2.0;
  c.cy = (c.height - 1) / 2.0;
  scene->projector.width = options.projector_width;
  scene->projector.height = options.projector_height;
  scene->timing.scale = 0;
  sim::SimWorld world(*scene);
  const fs::path stereo = dir / "captures" / "1";
  world.BlankProjector();
  world.SetStagePosition(0);
  const double mid = options.exposures[options.exposures.size() / 2];
  if (absl::Status s = Save(
          stereo / "left" / "ambient" /
              absl::StrCat("exp_", structured_light::ExposureTag(mid), ".png"),
          world.RenderExposure({mid, 100}, 8));
      !s.ok()) {
    return s;
  }
  for (int v = 0; v < 2; ++v) {
    world.SetStagePosition(v * options.baseline_mm);
    for (double e : options.exposures) {
      if (absl::Status s =
              Save(stereo / (v == 0 ? "left" : "right") / "stereo" /
                       absl::StrCat("exp_", structured_light::ExposureTag(e),
                                    ".png"),
                   world.RenderExposure({e, 100}, 8));
          !s.ok()) {
        return s;
      }
    }
  }
  if (options.truth) {
    absl::StatusOr<sim::StereoTruth> truth =
        world.Truth(0, options.baseline_mm);
    if (!truth.ok()) return truth.status();
    if (absl::Status s = sim::WriteStereoTruth(*truth, stereo / "truth");
        !s.ok()) {
      return s;
    }
  }
  if (options.structured_light) {
    const cv::Size psize(options.projector_width, options.projector_height);
    const fs::path sl = dir / "captures" / "2";
    for (int v = 0; v < 2; ++v) {
      world.SetStagePosition(v * options.baseline_mm);
      for (double e : options.sl_exposures) {
        for (const structured_light::Pattern& p :
             structured_light::AllPatterns(psize)) {
          absl::StatusOr<cv::Mat> pattern = structured_light::Render(p, psize);
          if (!pattern.ok()) return pattern.status();
          if (absl::Status s = world.SetProjectorPattern(*pattern); !s.ok()) {
            return s;
          }
          const std::string name =
              absl::StrCat("sl_", structured_light::FrameId(p), "_exp_",
                           structured_light::ExposureTag(e), ".png");
          if (absl::Status s = Save(
                  sl / (v == 0 ? "left" : "right") / "structured_light" / name,
                  world.RenderExposure({e, 100}, 8));
              !s.ok()) {
            return s;
          }
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
