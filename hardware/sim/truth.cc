// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/truth.h"

#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/base/status_macros.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/middlebury.h"

namespace hdrstereo::sim {
namespace {

constexpr float kInfF = std::numeric_limits<float>::infinity();

// Fills disparity and visibility of `self` towards `other`.
void Correspond(const Renderer& renderer, const View& self, const View& other,
                bool self_is_left, ViewTruth* truth) {
  const CameraIntrinsics& in = self.intrinsics;
  truth->disparity.create(in.height, in.width, CV_32FC1);
  truth->disparity_y.create(in.height, in.width, CV_32FC1);
  truth->nonoccluded.create(in.height, in.width, CV_8UC1);
  cv::parallel_for_(cv::Range(0, in.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      const float* depth = truth->depth.ptr<float>(y);
      float* disp = truth->disparity.ptr<float>(y);
      float* disp_y = truth->disparity_y.ptr<float>(y);
      uint8_t* vis = truth->nonoccluded.ptr<uint8_t>(y);
      for (int x = 0; x < in.width; ++x) {
        if (!std::isfinite(depth[x])) {
          disp[x] = kInfF;
          disp_y[x] = kInfF;
          vis[x] = 0;
          continue;
        }
        // Recompute the hit in double precision (depth is stored as float).
        const Vec3 dir =
            self.rotation * Vec3((x - in.cx) / in.fx, (y - in.cy) / in.fy, 1.0);
        Hit hit;
        if (!renderer.Intersect(self.center, dir, 0.0,
                                std::numeric_limits<double>::infinity(),
                                &hit)) {
          disp[x] = kInfF;
          disp_y[x] = kInfF;
          vis[x] = 0;
          continue;
        }
        cv::Point2d p;
        double z = 0;
        if (!other.Project(hit.point, &p, &z)) {
          disp[x] = kInfF;
          disp_y[x] = kInfF;
          vis[x] = 0;
          continue;
        }
        disp[x] = static_cast<float>(self_is_left ? x - p.x : p.x - x);
        disp_y[x] = static_cast<float>(p.y - y);
        const bool inside = p.x > -0.5 && p.x < in.width - 0.5 && p.y > -0.5 &&
                            p.y < in.height - 0.5;
        const bool hidden = renderer.Blocked(other.center, hit.point,
                                             /*shadow_casters_only=*/false);
        vis[x] = inside && !hidden ? 255 : 0;
      }
    }
  });
}

}  // namespace

absl::StatusOr<StereoTruth> ComputeStereoTruth(
    const Renderer& renderer, double left_mm, double baseline_mm,
    const cv::Mat& projector_pattern) {
  const Scene& scene = renderer.scene();
  const double right_mm = left_mm + baseline_mm;
  if (!(baseline_mm > 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("baseline must be > 0 mm, got ", baseline_mm));
  }
  if (left_mm < 0 || right_mm > scene.rig.travel_mm + 1e-9) {
    return absl::InvalidArgumentError(
        absl::StrFormat("stage positions %.3f and %.3f mm must lie within the "
                        "travel 0..%.3f mm",
                        left_mm, right_mm, scene.rig.travel_mm));
  }
  StereoTruth truth;
  truth.left_mm = left_mm;
  truth.baseline_mm = baseline_mm;
  truth.rectified = scene.rig.IsIdeal();
  truth.intrinsics = scene.camera;
  const View left = CameraView(scene, left_mm);
  const View right = CameraView(scene, right_mm);
  for (int i = 0; i < 2; ++i) {
    const View& self = i == 0 ? left : right;
    ViewTruth& vt = i == 0 ? truth.left : truth.right;
    RadianceFrame frame = renderer.Render(self, projector_pattern);
    vt.radiance = frame.radiance;
    vt.depth = frame.depth;
    vt.object_id = frame.object_id;
    Correspond(renderer, self, i == 0 ? right : left, i == 0, &vt);
  }
  return truth;
}

absl::Status WriteStereoTruth(const StereoTruth& truth,
                              const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat("cannot create ", dir.string(), ": ", ec.message()));
  }
  for (int i = 0; i < 2; ++i) {
    const ViewTruth& vt = i == 0 ? truth.left : truth.right;
    const std::string n = std::to_string(i);
    RETURN_IF_ERROR(io::WritePfm(dir / ("radiance" + n + ".pfm"), vt.radiance));
    RETURN_IF_ERROR(io::WritePfm(dir / ("depth" + n + ".pfm"), vt.depth));
    RETURN_IF_ERROR(io::WritePfm(dir / ("disp" + n + ".pfm"), vt.disparity));
    RETURN_IF_ERROR(
        io::WritePng(dir / ("nonocc" + n + ".png"), vt.nonoccluded));
    if (!truth.rectified) {
      RETURN_IF_ERROR(
          io::WritePfm(dir / ("dispy" + n + ".pfm"), vt.disparity_y));
    }
  }
  // doffs = 0: both views share the same intrinsics; ndisp a multiple of 16
  // above the largest disparity.
  const CameraIntrinsics& c = truth.intrinsics;
  double max_disp = 0;
  cv::Mat finite = truth.left.disparity.clone();
  finite.setTo(0, finite == kInfF);
  cv::minMaxLoc(finite, nullptr, &max_disp);
  io::Calib calib;
  calib.fx = c.fx;
  calib.fy = c.fy;
  calib.cx = c.cx;
  calib.cy = c.cy;
  calib.baseline_mm = truth.baseline_mm;
  calib.width = c.width;
  calib.height = c.height;
  calib.ndisp = static_cast<int>(std::ceil(max_disp / 16.0) * 16);
  calib.extra = {{"left_stage_mm", absl::StrFormat("%.6f", truth.left_mm)}};
  return io::WriteCalib(dir / io::kCalibFile, calib);
}

}  // namespace hdrstereo::sim
