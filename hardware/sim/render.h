// SPDX-License-Identifier: GPL-3.0-or-later
//
// Ray-cast renderer: one primary ray through each pixel centre, Lambertian
// shading with ambient light, point lights and the projector (each with hard
// shadows), plus emitted radiance. The output is exact scene radiance, z-depth
// and the id of the visible object, so it doubles as ground truth.
#ifndef HDRSTEREO_HARDWARE_SIM_RENDER_H_
#define HDRSTEREO_HARDWARE_SIM_RENDER_H_

#include <opencv2/core.hpp>
#include <vector>

#include "hardware/sim/scene.h"

namespace hdrstereo::sim {

// A pinhole camera: pixel (u, v) sees the ray
//   center + t * rotation * ((u - cx) / fx, (v - cy) / fy, 1),
// and t is then the z-depth of the hit point in this camera's frame.
struct View {
  Vec3 center{0, 0, 0};
  Mat3 rotation = Mat3::eye();  // camera-to-world
  CameraIntrinsics intrinsics;

  // Projects a world point; returns false when it is behind the camera.
  bool Project(const Vec3& world, cv::Point2d* pixel, double* depth) const;
};

// The camera of `scene` with the stage at `stage_mm`.
View CameraView(const Scene& scene, double stage_mm);

struct RadianceFrame {
  cv::Mat radiance;   // CV_32FC3, BGR, cd/m^2
  cv::Mat depth;      // CV_32FC1, z-depth in mm; +inf where nothing is hit
  cv::Mat object_id;  // CV_16UC1, 0 = nothing, i + 1 = scene.objects[i]
};

struct Hit {
  double t = 0;
  int object = -1;
  Vec3 point;
  Vec3 normal;  // unit, outward (planes: the plane's normal)
};

class Renderer {
 public:
  explicit Renderer(Scene scene);

  const Scene& scene() const { return scene_; }

  // Renders `view`. `projector_pattern` is what the projector shows:
  // CV_8UC1/CV_8UC3 (BGR) or CV_32FC1/CV_32FC3 in [0, 1]; it is resized with
  // nearest-neighbour sampling to the projector's resolution if needed. An
  // empty pattern means the projector is off (emits nothing, not even its
  // black level). Runs on all cores (cv::parallel_for_ over rows).
  RadianceFrame Render(const View& view,
                       const cv::Mat& projector_pattern) const;

  // Nearest hit of the ray origin + t * dir with t in (t_min, t_max).
  bool Intersect(const Vec3& origin, const Vec3& dir, double t_min,
                 double t_max, Hit* hit) const;
  // Whether any object lies strictly between `from` and `to`. With
  // `shadow_casters_only`, objects with casts_shadow == false are ignored.
  bool Blocked(const Vec3& from, const Vec3& to,
               bool shadow_casters_only) const;

  // Lambertian albedo (RGB) of object `index` at world point `p`.
  Rgb AlbedoAt(int index, const Vec3& p) const;

 private:
  struct ProjectorImage;
  // Hit of object `index` with t in (t_min, t_max); boxes also report the
  // entered face as a signed 1-based local axis.
  bool IntersectOne(int index, const Vec3& origin, const Vec3& dir,
                    double t_min, double t_max, double* t, int* face) const;
  Rgb Shade(const Hit& hit, const Vec3& ray_dir,
            const ProjectorImage* projector) const;

  Scene scene_;
  std::vector<Mat3> inverse_rotation_;  // boxes: world-to-local
  std::vector<Vec3> v_axis_;            // planes: normal x u_axis
  std::vector<double> bound_radius2_;   // boxes: bounding sphere radius^2
};

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_RENDER_H_
