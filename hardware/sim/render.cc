// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "hardware/sim/noise.h"

namespace hdrstereo::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
// Offset of shadow-ray origins from the surface, in mm.
constexpr double kSurfaceEpsilon = 1e-3;

// Unrolled 3-vector helpers for the hot loops (cv::Vec's generic loops are
// not unrolled by GCC at -O2).
inline double Dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline Vec3 Sub(const Vec3& a, const Vec3& b) {
  return Vec3(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

}  // namespace

// The projector's emitted intensity per pattern pixel, RGB, as a fraction of
// max_intensity_cd (black level, gamma and blur applied).
struct Renderer::ProjectorImage {
  cv::Mat emitted;  // CV_32FC3, BGR, projector resolution
};

bool View::Project(const Vec3& world, cv::Point2d* pixel, double* depth) const {
  Vec3 c = rotation.t() * (world - center);
  if (c[2] <= 0) return false;
  pixel->x = intrinsics.fx * c[0] / c[2] + intrinsics.cx;
  pixel->y = intrinsics.fy * c[1] / c[2] + intrinsics.cy;
  *depth = c[2];
  return true;
}

View CameraView(const Scene& scene, double stage_mm) {
  View v;
  v.center = scene.rig.CameraCenter(stage_mm);
  v.rotation = scene.rig.CameraRotation();
  v.intrinsics = scene.camera;
  return v;
}

Renderer::Renderer(Scene scene) : scene_(std::move(scene)) {
  for (const Object& o : scene_.objects) {
    inverse_rotation_.push_back(o.rotation.t());
    const Vec3 half = o.box_size * 0.5;
    bound_radius2_.push_back(Dot(half, half) * (1 + 1e-9));
    v_axis_.push_back(o.normal.cross(o.u_axis));
  }
}

bool Renderer::IntersectOne(int index, const Vec3& origin, const Vec3& dir,
                            double t_min, double t_max, double* t_out,
                            int* face_out) const {
  const Object& o = scene_.objects[index];
  switch (o.shape) {
    case ShapeKind::kPlane: {
      const double denom = Dot(o.normal, dir);
      if (std::abs(denom) < 1e-15) return false;
      const double t = Dot(o.normal, Sub(o.center, origin)) / denom;
      if (!(t > t_min && t < t_max)) return false;
      if (o.size[0] > 0) {
        const Vec3 d(origin[0] + t * dir[0] - o.center[0],
                     origin[1] + t * dir[1] - o.center[1],
                     origin[2] + t * dir[2] - o.center[2]);
        if (std::abs(Dot(d, o.u_axis)) > o.size[0] / 2 ||
            std::abs(Dot(d, v_axis_[index])) > o.size[1] / 2) {
          return false;
        }
      }
      if (t_out != nullptr) *t_out = t;
      return true;
    }
    case ShapeKind::kSphere: {
      const Vec3 oc = Sub(origin, o.center);
      const double a = Dot(dir, dir), b = Dot(oc, dir),
                   c = Dot(oc, oc) - o.radius * o.radius;
      const double disc = b * b - a * c;
      if (disc < 0) return false;
      const double s = std::sqrt(disc);
      double t = (-b - s) / a;
      if (!(t > t_min)) t = (-b + s) / a;
      if (!(t > t_min && t < t_max)) return false;
      if (t_out != nullptr) *t_out = t;
      return true;
    }
    case ShapeKind::kBox: {
      const Vec3 oc = Sub(origin, o.center);
      {  // Cheap rejection with the bounding sphere.
        const double a = Dot(dir, dir), b = Dot(oc, dir),
                     c = Dot(oc, oc) - bound_radius2_[index];
        if (b * b - a * c < 0) return false;
      }
      const Mat3& r = inverse_rotation_[index];
      const double lo[3] = {
          r(0, 0) * oc[0] + r(0, 1) * oc[1] + r(0, 2) * oc[2],
          r(1, 0) * oc[0] + r(1, 1) * oc[1] + r(1, 2) * oc[2],
          r(2, 0) * oc[0] + r(2, 1) * oc[1] + r(2, 2) * oc[2]};
      const double ld[3] = {
          r(0, 0) * dir[0] + r(0, 1) * dir[1] + r(0, 2) * dir[2],
          r(1, 0) * dir[0] + r(1, 1) * dir[1] + r(1, 2) * dir[2],
          r(2, 0) * dir[0] + r(2, 1) * dir[1] + r(2, 2) * dir[2]};
      double t_near = -kInf, t_far = kInf;
      int face_near = 0, face_far = 0;
      for (int k = 0; k < 3; ++k) {
        const double half = o.box_size[k] / 2;
        if (std::abs(ld[k]) < 1e-15) {
          if (std::abs(lo[k]) > half) return false;
          continue;
        }
        double t1 = (-half - lo[k]) / ld[k], t2 = (half - lo[k]) / ld[k];
        int f1 = -(k + 1), f2 = k + 1;
        if (t1 > t2) {
          std::swap(t1, t2);
          std::swap(f1, f2);
        }
        if (t1 > t_near) {
          t_near = t1;
          face_near = f1;
        }
        if (t2 < t_far) {
          t_far = t2;
          face_far = f2;
        }
      }
      if (t_near > t_far) return false;
      double t = t_near;
      int face = face_near;
      if (!(t > t_min)) {
        t = t_far;
        face = face_far;
      }
      if (!(t > t_min && t < t_max)) return false;
      if (t_out != nullptr) *t_out = t;
      if (face_out != nullptr) *face_out = face;
      return true;
    }
  }
  return false;
}

bool Renderer::Intersect(const Vec3& origin, const Vec3& dir, double t_min,
                         double t_max, Hit* hit) const {
  double best = t_max;
  int best_index = -1;
  int best_face = 0;  // boxes: signed local axis of the entered face (1-based)
  for (size_t i = 0; i < scene_.objects.size(); ++i) {
    double t = 0;
    int face = 0;
    if (IntersectOne(static_cast<int>(i), origin, dir, t_min, best, &t,
                     &face)) {
      best = t;
      best_index = static_cast<int>(i);
      best_face = face;
    }
  }
  if (best_index < 0) return false;
  if (hit == nullptr) return true;
  const Object& o = scene_.objects[best_index];
  hit->t = best;
  hit->object = best_index;
  hit->point = origin + best * dir;
  switch (o.shape) {
    case ShapeKind::kPlane:
      hit->normal = o.normal;
      break;
    case ShapeKind::kSphere:
      hit->normal = (hit->point - o.center) / o.radius;
      break;
    case ShapeKind::kBox: {
      Vec3 local(0, 0, 0);
      local[std::abs(best_face) - 1] = best_face > 0 ? 1.0 : -1.0;
      hit->normal = o.rotation * local;
      break;
    }
  }
  return true;
}

bool Renderer::Blocked(const Vec3& from, const Vec3& to,
                       bool shadow_casters_only) const {
  const Vec3 dir = to - from;
  const double len = cv::norm(dir);
  if (len <= 0) return false;
  const double t_max = 1.0 - kSurfaceEpsilon / len;
  // Any hit will do: test the objects one at a time, skipping those that
  // cast no shadow (lamps) when asked to.
  for (size_t i = 0; i < scene_.objects.size(); ++i) {
    if (shadow_casters_only && !scene_.objects[i].casts_shadow) continue;
    if (IntersectOne(static_cast<int>(i), from, dir, 0.0, t_max, nullptr,
                     nullptr)) {
      return true;
    }
  }
  return false;
}

Rgb Renderer::AlbedoAt(int index, const Vec3& p) const {
  const Object& o = scene_.objects[index];
  const Texture& tex = o.material.texture;
  if (tex.kind == TextureKind::kUniform) return o.material.albedo;
  // Surface coordinates in mm.
  double u = 0, v = 0;
  switch (o.shape) {
    case ShapeKind::kPlane: {
      const Vec3 d = p - o.center;
      u = d.dot(o.u_axis);
      v = d.dot(v_axis_[index]);
      if (o.size[0] > 0) {  // texture origin at the plane's corner
        u += o.size[0] / 2;
        v += o.size[1] / 2;
      }
      break;
    }
    case ShapeKind::kBox: {
      const Vec3 l = inverse_rotation_[index] * (p - o.center);
      int axis = 0;
      double best = -1;
      for (int k = 0; k < 3; ++k) {
        const double r = std::abs(l[k]) / (o.box_size[k] / 2);
        if (r > best) {
          best = r;
          axis = k;
        }
      }
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      u = l[a] + o.box_size[a] / 2;
      v = l[b] + o.box_size[b] / 2;
      break;
    }
    case ShapeKind::kSphere: {
      const Vec3 d = (p - o.center) / o.radius;
      u = std::atan2(d[0], -d[2]) * o.radius;
      v = std::asin(std::clamp(d[1], -1.0, 1.0)) * o.radius;
      break;
    }
  }
  double w = 0;  // weight of second_albedo
  if (tex.kind == TextureKind::kChecker) {
    const int64_t i = static_cast<int64_t>(std::floor(u / tex.square_mm));
    const int64_t j = static_cast<int64_t>(std::floor(v / tex.square_mm));
    w = ((i + j) & 1) ? 1.0 : 0.0;
  } else {
    w = FractalNoise2d(u / tex.scale_mm, v / tex.scale_mm, tex.octaves,
                       tex.seed);
  }
  return (1.0 - w) * o.material.albedo + w * tex.second_albedo;
}

Rgb Renderer::Shade(const Hit& hit, const Vec3& ray_dir,
                    const ProjectorImage* projector) const {
  const Object& o = scene_.objects[hit.object];
  Vec3 n = hit.normal;
  if (n.dot(ray_dir) > 0) n = -n;  // two-sided surfaces
  const Vec3 origin = hit.point + kSurfaceEpsilon * n;
  Rgb irradiance = scene_.ambient_lux;
  for (const PointLight& light : scene_.lights) {
    const Vec3 l = light.position - hit.point;
    const double d2 = l.dot(l);
    // A light lying on the surface lies in its tangent plane: every point
    // around it sees it at grazing incidence (cos theta = 0) and gets
    // nothing from it, and so does the point under it, where the direction
    // is 0/0 (NaN, which the test below would let through).
    if (!(d2 > 0)) continue;
    const double cos_theta = n.dot(l) / std::sqrt(d2);
    if (cos_theta <= 0) continue;
    if (Blocked(origin, light.position, /*shadow_casters_only=*/true)) continue;
    irradiance += light.color * (light.intensity_cd * cos_theta / (d2 * 1e-6));
  }
  if (projector != nullptr) {
    const ProjectorModel& pm = scene_.projector;
    const Vec3 l = pm.position - hit.point;
    const double d2 = l.dot(l);
    const double cos_theta = n.dot(l) / std::sqrt(d2);
    const Vec3 q = pm.rotation.t() * (hit.point - pm.position);
    if (cos_theta > 0 && q[2] > 0) {
      const double f = pm.focal_px();
      const double x = f * q[0] / q[2] + pm.cx();
      const double y = f * q[1] / q[2] + pm.cy();
      const double col = std::floor(x + 0.5), row = std::floor(y + 0.5);
      if (col >= 0 && col < pm.width && row >= 0 && row < pm.height &&
          !Blocked(origin, pm.position, /*shadow_casters_only=*/true)) {
        const cv::Vec3f e = projector->emitted.at<cv::Vec3f>(
            static_cast<int>(row), static_cast<int>(col));
        const double k = pm.max_intensity_cd * cos_theta / (d2 * 1e-6);
        irradiance += Rgb(e[2] * k, e[1] * k, e[0] * k);
      }
    }
  }
  const Rgb albedo = AlbedoAt(hit.object, hit.point);
  Rgb radiance = o.material.emission;
  for (int c = 0; c < 3; ++c) radiance[c] += albedo[c] * irradiance[c] / kPi;
  return radiance;
}

RadianceFrame Renderer::Render(const View& view,
                               const cv::Mat& projector_pattern) const {
  const CameraIntrinsics& in = view.intrinsics;
  RadianceFrame frame;
  frame.radiance.create(in.height, in.width, CV_32FC3);
  frame.depth.create(in.height, in.width, CV_32FC1);
  frame.object_id.create(in.height, in.width, CV_16UC1);

  ProjectorImage projector;
  const bool projector_on =
      scene_.projector.present && !projector_pattern.empty();
  if (projector_on) {
    const ProjectorModel& pm = scene_.projector;
    cv::Mat p;
    if (projector_pattern.channels() == 1) {
      cv::cvtColor(projector_pattern, p, cv::COLOR_GRAY2BGR);
    } else {
      p = projector_pattern;
    }
    p.convertTo(p, CV_32FC3, p.depth() == CV_8U ? 1.0 / 255.0 : 1.0);
    if (p.cols != pm.width || p.rows != pm.height) {
      cv::resize(p, p, cv::Size(pm.width, pm.height), 0, 0, cv::INTER_NEAREST);
    }
    cv::Mat emitted(p.size(), CV_32FC3);
    p.forEach<cv::Vec3f>([&](const cv::Vec3f& v, const int* pos) {
      cv::Vec3f e;
      for (int c = 0; c < 3; ++c) {
        const float x = std::clamp(v[c], 0.0f, 1.0f);
        e[c] = static_cast<float>(
            pm.black_level + (1.0 - pm.black_level) *
                                 std::pow(static_cast<double>(x), pm.gamma));
      }
      emitted.at<cv::Vec3f>(pos[0], pos[1]) = e;
    });
    if (pm.blur_px > 0) {
      cv::GaussianBlur(emitted, emitted, cv::Size(), pm.blur_px, pm.blur_px,
                       cv::BORDER_REPLICATE);
    }
    projector.emitted = emitted;
  }

  cv::parallel_for_(
      cv::Range(0, in.height),
      [&](const cv::Range& rows) {
        for (int y = rows.start; y < rows.end; ++y) {
          auto* rad = frame.radiance.ptr<cv::Vec3f>(y);
          auto* dep = frame.depth.ptr<float>(y);
          auto* ids = frame.object_id.ptr<uint16_t>(y);
          const double yn = (y - in.cy) / in.fy;
          for (int x = 0; x < in.width; ++x) {
            const Vec3 dir = view.rotation * Vec3((x - in.cx) / in.fx, yn, 1.0);
            Hit hit;
            if (!Intersect(view.center, dir, 0.0, kInf, &hit)) {
              rad[x] = cv::Vec3f(0, 0, 0);
              dep[x] = std::numeric_limits<float>::infinity();
              ids[x] = 0;
              continue;
            }
            const Rgb l = Shade(hit, dir, projector_on ? &projector : nullptr);
            rad[x] =
                cv::Vec3f(static_cast<float>(l[2]), static_cast<float>(l[1]),
                          static_cast<float>(l[0]));
            dep[x] = static_cast<float>(hit.t);
            ids[x] = static_cast<uint16_t>(hit.object + 1);
          }
        }
      },
      std::max(1, in.height / 16));
  return frame;
}

}  // namespace hdrstereo::sim
