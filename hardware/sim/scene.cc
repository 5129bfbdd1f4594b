// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "hardware/sim/bundled_scenes.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/image.h"
#include "processing/io/json_input.h"
#include "processing/io/relative_path.h"

namespace hdrstereo::sim {
namespace {

using Json = nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

// Limits on what a scene file declares (scenes are shared between labs), so
// that neither parsing nor rendering one runs out of memory or time:
// - a scene file is a page of JSON (the bundled ones are 2-3 KB);
constexpr size_t kMaxSceneBytes = 1 << 20;
// - coordinates and lengths within 10 km, and checker squares and noise
//   features of at least 1 um, so that the renderer's texture cell indices
//   (length / feature) stay far inside int64;
constexpr double kMaxLengthMm = 1e7;
constexpr double kMinFeatureMm = 1e-3;
// - the camera within OpenCV's decoded-image limits and at most 2^26 pixels
//   (a 61 MP sensor is 9504 x 6336): the renderer keeps 18 bytes a pixel
//   besides the images;
constexpr int64_t kMaxCameraPixels = int64_t{1} << 26;
// - the projector at most kMaxProjectorSide pixels each way (the largest
//   frame buffer a display offers) and 2^27 pixels (a 16K display is
//   15360 x 8640): its pattern is rendered as 12 bytes a pixel;
constexpr int64_t kMaxProjectorPixels = int64_t{1} << 27;
// - every pixel is traced against every object and towards every light
//   (and object ids are 16-bit);
constexpr size_t kMaxObjects = 256;
constexpr size_t kMaxLights = 16;
// - a fault trigger lists a few call numbers, each an int.
constexpr size_t kMaxTriggerCalls = 1000;
constexpr int kMaxCallNumber = 1000000000;
// - names at most kMaxNameBytes, a description 4 KB, paths PATH_MAX
//   (io::kMaxRelativePathBytes).
constexpr size_t kMaxDescriptionBytes = 4096;
// Calibration poses a capture asks for.
constexpr size_t kMaxBoardPoses = 64;

// Thrown inside the parser only; ParseScene turns it into a Status.
struct FieldError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw FieldError(absl::StrCat(path, ": ", what));
}

// Fails with `status`'s message unless it is OK.
void Check(const absl::Status& status) {
  if (!status.ok()) throw FieldError(std::string(status.message()));
}

std::string Join(const std::string& path, const std::string& key) {
  return path.empty() ? key : absl::StrCat(path, ".", key);
}

void CheckKeys(const Json& j, const std::string& path,
               const std::set<std::string>& allowed) {
  if (!j.is_object()) Fail(path.empty() ? "scene" : path, "expected an object");
  for (const auto& [key, value] : j.items()) {
    if (!allowed.count(key)) {
      Fail(path.empty() ? "scene" : path,
           absl::StrCat("unknown field ", QuoteInput(key),
                        " (allowed: ", absl::StrJoin(allowed, ", "), ")"));
    }
  }
}

// obj[key] (when present) with at most `max` elements, else nullptr.
const Json* GetArray(const Json& obj, const std::string& path,
                     const std::string& key, size_t max) {
  if (!obj.contains(key)) return nullptr;
  const Json& j = obj.at(key);
  if (!j.is_array()) Fail(Join(path, key), "expected an array");
  if (j.size() > max) {
    Fail(Join(path, key),
         absl::StrCat(j.size(), " elements, more than the limit of ", max));
  }
  return &j;
}

double Number(const Json& j, const std::string& path) {
  if (!j.is_number()) Fail(path, "expected a number");
  double v = j.get<double>();
  if (!std::isfinite(v)) Fail(path, "expected a finite number");
  return v;
}

// Reads obj[key] if present; checks lo <= v <= hi.
double GetNumber(const Json& obj, const std::string& path,
                 const std::string& key, double fallback, double lo,
                 double hi) {
  if (!obj.contains(key)) return fallback;
  const std::string p = Join(path, key);
  double v = Number(obj.at(key), p);
  if (v < lo || v > hi) {
    Fail(p, absl::StrCat("must be in [", lo, ", ", hi, "], got ", v));
  }
  return v;
}

// Reads obj[key] if present; checks 0 < v <= hi.
double GetPositive(const Json& obj, const std::string& path,
                   const std::string& key, double fallback, double hi) {
  if (!obj.contains(key)) return fallback;
  const std::string p = Join(path, key);
  double v = Number(obj.at(key), p);
  if (!(v > 0 && v <= hi)) {
    Fail(p, absl::StrCat("must be in (0, ", hi, "], got ", v));
  }
  return v;
}

int Int(const Json& j, const std::string& path, int lo, int hi) {
  const absl::StatusOr<int64_t> v = io::JsonIntInRange(j, path, lo, hi);
  Check(v.status());
  return static_cast<int>(*v);
}

int GetInt(const Json& obj, const std::string& path, const std::string& key,
           int fallback, int lo, int hi) {
  if (!obj.contains(key)) return fallback;
  return Int(obj.at(key), Join(path, key), lo, hi);
}

bool GetBool(const Json& obj, const std::string& path, const std::string& key,
             bool fallback) {
  if (!obj.contains(key)) return fallback;
  if (!obj.at(key).is_boolean()) Fail(Join(path, key), "expected true/false");
  return obj.at(key).get<bool>();
}

std::string GetString(const Json& obj, const std::string& path,
                      const std::string& key, const std::string& fallback,
                      size_t max_bytes = kMaxNameBytes) {
  if (!obj.contains(key)) return fallback;
  if (!obj.at(key).is_string()) Fail(Join(path, key), "expected a string");
  std::string v = obj.at(key).get<std::string>();
  if (v.size() > max_bytes) {
    Fail(Join(path, key),
         absl::StrCat(QuoteInput(v), " is longer than the limit of ", max_bytes,
                      " bytes"));
  }
  return v;
}

// Positions, lengths and angles: each within +-kMaxLengthMm.
Vec3 ToVec3(const Json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) Fail(path, "expected 3 numbers");
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    const std::string p = absl::StrCat(path, "[", i, "]");
    v[i] = Number(j[i], p);
    if (std::abs(v[i]) > kMaxLengthMm) {
      Fail(p, absl::StrCat("must be in [", -kMaxLengthMm, ", ", kMaxLengthMm,
                           "], got ", v[i]));
    }
  }
  return v;
}

Vec3 GetVec3(const Json& obj, const std::string& path, const std::string& key,
             const Vec3& fallback) {
  if (!obj.contains(key)) return fallback;
  return ToVec3(obj.at(key), Join(path, key));
}

Vec3 GetDirection(const Json& obj, const std::string& path,
                  const std::string& key, const Vec3& fallback) {
  Vec3 v = GetVec3(obj, path, key, fallback);
  double n = cv::norm(v);
  if (!(n > 1e-12)) Fail(Join(path, key), "must not be the zero vector");
  return v / n;
}

// A colour: one number (grey) or [r, g, b], each in [lo, hi].
Rgb GetColor(const Json& obj, const std::string& path, const std::string& key,
             const Rgb& fallback, double lo, double hi) {
  if (!obj.contains(key)) return fallback;
  const std::string p = Join(path, key);
  const Json& j = obj.at(key);
  Rgb c;
  if (j.is_number()) {
    double v = Number(j, p);
    c = Rgb(v, v, v);
  } else if (j.is_array() && j.size() == 3) {
    c = ToVec3(j, p);
  } else {
    Fail(p, "expected a number or 3 numbers [r, g, b]");
  }
  for (int i = 0; i < 3; ++i) {
    if (c[i] < lo || c[i] > hi) {
      Fail(p, absl::StrCat("values must be in [", lo, ", ", hi, "]"));
    }
  }
  return c;
}

Mat3 RotationFromEulerDeg(const Vec3& deg) {
  const double rx = deg[0] * kPi / 180, ry = deg[1] * kPi / 180,
               rz = deg[2] * kPi / 180;
  Mat3 x(1, 0, 0, 0, std::cos(rx), -std::sin(rx), 0, std::sin(rx),
         std::cos(rx));
  Mat3 y(std::cos(ry), 0, std::sin(ry), 0, 1, 0, -std::sin(ry), 0,
         std::cos(ry));
  Mat3 z(std::cos(rz), -std::sin(rz), 0, std::sin(rz), std::cos(rz), 0, 0, 0,
         1);
  return z * y * x;
}

// Rotation whose z axis looks from `from` to `to`, with y pointing down
// (world +y) as far as possible.
Mat3 LookAt(const Vec3& from, const Vec3& to, const std::string& path) {
  Vec3 z = to - from;
  double n = cv::norm(z);
  if (n < 1e-9) Fail(path, "look_at_mm must differ from position_mm");
  z /= n;
  Vec3 down(0, 1, 0);
  Vec3 x = down.cross(z);
  if (cv::norm(x) < 1e-6) x = Vec3(1, 0, 0);
  x /= cv::norm(x);
  Vec3 y = z.cross(x);
  return Mat3(x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]);
}

// A FaultTrigger at obj[key]: {"calls": [...], "probability": p}, plus the
// `extra` fields its caller reads.
FaultTrigger ParseTrigger(const Json& obj, const std::string& path,
                          const std::string& key,
                          std::set<std::string> extra = {}) {
  FaultTrigger t;
  if (!obj.contains(key)) return t;
  const std::string p = Join(path, key);
  const Json& j = obj.at(key);
  extra.insert({"calls", "probability"});
  CheckKeys(j, p, extra);
  if (const Json* calls = GetArray(j, p, "calls", kMaxTriggerCalls)) {
    for (size_t i = 0; i < calls->size(); ++i) {
      t.calls.push_back(Int((*calls)[i], absl::StrCat(p, ".calls[", i, "]"), 1,
                            kMaxCallNumber));
    }
  }
  t.probability = GetNumber(j, p, "probability", 0.0, 0.0, 1.0);
  return t;
}

// A FaultWindow at obj[key]: the trigger's fields and "lasts", plus the
// `extra` fields its caller reads.
FaultWindow ParseWindow(const Json& obj, const std::string& path,
                        const std::string& key,
                        std::set<std::string> extra = {}) {
  FaultWindow w;
  if (!obj.contains(key)) return w;
  extra.insert("lasts");
  w.begins = ParseTrigger(obj, path, key, extra);
  w.lasts = GetInt(obj.at(key), Join(path, key), "lasts", w.lasts, 1, 1000000);
  return w;
}

// A Zaber warning flag: two capital letters, or "--" (none) where
// `none_allowed`.
std::string GetWarningFlag(const Json& obj, const std::string& path,
                           const std::string& key, const std::string& fallback,
                           bool none_allowed) {
  std::string flag = GetString(obj, path, key, fallback);
  const bool letters =
      flag.size() == 2 && std::isupper(flag[0]) && std::isupper(flag[1]);
  if (!letters && !(none_allowed && flag == "--")) {
    Fail(Join(path, key), none_allowed
                              ? "expected two capital letters or \"--\""
                              : "expected two capital letters");
  }
  return flag;
}

ResponseCurve ParseResponse(const Json& obj, const std::string& path,
                            const std::string& key,
                            const ResponseCurve& fallback) {
  if (!obj.contains(key)) return fallback;
  const std::string p = Join(path, key);
  const Json& j = obj.at(key);
  CheckKeys(j, p, {"kind", "gamma", "contrast"});
  ResponseCurve r = fallback;
  std::string kind = GetString(j, p, "kind", "s_curve");
  if (kind == "linear") {
    r.kind = ResponseKind::kLinear;
  } else if (kind == "gamma") {
    r.kind = ResponseKind::kGamma;
  } else if (kind == "s_curve") {
    r.kind = ResponseKind::kSCurve;
  } else {
    Fail(p + ".kind", absl::StrCat("expected linear, gamma or s_curve, got ",
                                   QuoteInput(kind)));
  }
  r.gamma = GetNumber(j, p, "gamma", r.gamma, 0.1, 10.0);
  r.contrast = GetNumber(j, p, "contrast", r.contrast, 0.2, 10.0);
  return r;
}

Material ParseMaterial(const Json& obj, const std::string& path) {
  Material m;
  if (!obj.contains("material")) return m;
  const std::string p = path + ".material";
  const Json& j = obj.at("material");
  CheckKeys(j, p, {"albedo", "texture", "emission"});
  m.albedo = GetColor(j, p, "albedo", m.albedo, 0.0, 1.0);
  m.emission = GetColor(j, p, "emission", m.emission, 0.0, 1e9);
  if (j.contains("texture")) {
    const std::string tp = p + ".texture";
    const Json& t = j.at("texture");
    CheckKeys(
        t, tp,
        {"kind", "second_albedo", "square_mm", "scale_mm", "octaves", "seed"});
    std::string kind = GetString(t, tp, "kind", "uniform");
    if (kind == "uniform") {
      m.texture.kind = TextureKind::kUniform;
    } else if (kind == "checker") {
      m.texture.kind = TextureKind::kChecker;
    } else if (kind == "noise") {
      m.texture.kind = TextureKind::kNoise;
    } else {
      Fail(tp + ".kind",
           absl::StrCat("expected uniform, checker or noise, got ",
                        QuoteInput(kind)));
    }
    m.texture.second_albedo =
        GetColor(t, tp, "second_albedo", m.texture.second_albedo, 0.0, 1.0);
    m.texture.square_mm = GetNumber(t, tp, "square_mm", m.texture.square_mm,
                                    kMinFeatureMm, kMaxLengthMm);
    m.texture.scale_mm = GetNumber(t, tp, "scale_mm", m.texture.scale_mm,
                                   kMinFeatureMm, kMaxLengthMm);
    m.texture.octaves = GetInt(t, tp, "octaves", m.texture.octaves, 1, 8);
    m.texture.seed = static_cast<uint64_t>(
        GetInt(t, tp, "seed", static_cast<int>(m.texture.seed), 0, 1 << 30));
  }
  return m;
}

Object ParseObject(const Json& j, const std::string& p) {
  CheckKeys(j, p,
            {"name", "type", "center_mm", "normal", "u_axis", "size_mm",
             "rotation_deg", "radius_mm", "material", "casts_shadow"});
  Object o;
  o.name = GetString(j, p, "name", "");
  if (!j.contains("type")) Fail(p + ".type", "missing (plane, box or sphere)");
  std::string type = GetString(j, p, "type", "");
  if (!j.contains("center_mm")) Fail(p + ".center_mm", "missing");
  o.center = GetVec3(j, p, "center_mm", o.center);
  o.material = ParseMaterial(j, p);
  bool emitter = o.material.emission[0] > 0 || o.material.emission[1] > 0 ||
                 o.material.emission[2] > 0;
  o.casts_shadow = GetBool(j, p, "casts_shadow", !emitter);
  auto forbid = [&](std::initializer_list<const char*> keys) {
    for (const char* k : keys) {
      if (j.contains(k)) Fail(Join(p, k), "not used by a " + type);
    }
  };
  if (type == "plane") {
    o.shape = ShapeKind::kPlane;
    forbid({"radius_mm", "rotation_deg"});
    o.normal = GetDirection(j, p, "normal", o.normal);
    Vec3 hint = std::abs(o.normal[0]) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    Vec3 u = GetDirection(j, p, "u_axis", hint);
    u = u - u.dot(o.normal) * o.normal;
    if (cv::norm(u) < 1e-6) Fail(p + ".u_axis", "must not be along the normal");
    o.u_axis = u / cv::norm(u);
    if (j.contains("size_mm")) {
      const Json& s = j.at("size_mm");
      if (!s.is_array() || s.size() != 2) {
        Fail(p + ".size_mm", "a plane's size is 2 numbers [along u, along v]");
      }
      o.size = cv::Vec2d(Number(s[0], p + ".size_mm[0]"),
                         Number(s[1], p + ".size_mm[1]"));
      if (!(o.size[0] > 0 && o.size[1] > 0)) {
        Fail(p + ".size_mm",
             "must be > 0 (leave it out for an infinite plane)");
      }
      if (o.size[0] > kMaxLengthMm || o.size[1] > kMaxLengthMm) {
        Fail(p + ".size_mm", absl::StrCat("must be at most ", kMaxLengthMm));
      }
    }
  } else if (type == "box") {
    o.shape = ShapeKind::kBox;
    forbid({"radius_mm", "normal", "u_axis"});
    if (!j.contains("size_mm")) Fail(p + ".size_mm", "missing");
    o.box_size = GetVec3(j, p, "size_mm", o.box_size);
    for (int i = 0; i < 3; ++i) {
      if (!(o.box_size[i] > 0)) Fail(p + ".size_mm", "must be > 0");
    }
    o.rotation = RotationFromEulerDeg(GetVec3(j, p, "rotation_deg", Vec3()));
  } else if (type == "sphere") {
    o.shape = ShapeKind::kSphere;
    forbid({"normal", "u_axis", "size_mm", "rotation_deg"});
    if (!j.contains("radius_mm")) Fail(p + ".radius_mm", "missing");
    o.radius = GetPositive(j, p, "radius_mm", o.radius, kMaxLengthMm);
  } else {
    Fail(p + ".type",
         absl::StrCat("expected plane, box or sphere, got ", QuoteInput(type)));
  }
  return o;
}

Scene ParseSceneJson(const Json& root) {
  CheckKeys(root, "",
            {"name", "description", "seed", "camera", "rig", "sensor",
             "ambient_lux", "objects", "lights", "projector", "timing",
             "faults", "calibration_board"});
  Scene s;
  s.name = GetString(root, "", "name", "");
  s.description = GetString(root, "", "description", "", kMaxDescriptionBytes);
  s.seed = static_cast<uint64_t>(GetInt(root, "", "seed", 1, 0, 1 << 30));

  if (root.contains("camera")) {
    const Json& j = root.at("camera");
    CheckKeys(j, "camera", {"width", "height", "fx", "fy", "cx", "cy"});
    CameraIntrinsics& c = s.camera;
    const ImageLimits& limits = DecodedImageLimits();
    c.width = GetInt(
        j, "camera", "width", c.width, 8,
        static_cast<int>(std::min<int64_t>(limits.max_width, INT32_MAX)));
    c.height = GetInt(
        j, "camera", "height", c.height, 8,
        static_cast<int>(std::min<int64_t>(limits.max_height, INT32_MAX)));
    Check(CheckedMultiply("camera pixels (width x height)", c.width, c.height,
                          std::min(kMaxCameraPixels, limits.max_pixels))
              .status());
    // Focal lengths and the principal point in pixels.
    c.fx = GetPositive(j, "camera", "fx", c.fx, 1e7);
    c.fy = GetPositive(j, "camera", "fy", c.fx, 1e7);
    c.cx = GetNumber(j, "camera", "cx", (c.width - 1) / 2.0, -1e7, 1e7);
    c.cy = GetNumber(j, "camera", "cy", (c.height - 1) / 2.0, -1e7, 1e7);
  }
  if (root.contains("rig")) {
    const Json& j = root.at("rig");
    CheckKeys(j, "rig",
              {"origin_mm", "rotation_deg", "travel_mm", "misalignment"});
    RigModel& r = s.rig;
    r.origin = GetVec3(j, "rig", "origin_mm", r.origin);
    r.rotation =
        RotationFromEulerDeg(GetVec3(j, "rig", "rotation_deg", Vec3()));
    r.travel_mm = GetPositive(j, "rig", "travel_mm", r.travel_mm, kMaxLengthMm);
    if (j.contains("misalignment")) {
      const Json& m = j.at("misalignment");
      const std::string p = "rig.misalignment";
      CheckKeys(m, p, {"axis_dy_per_mm", "axis_dz_per_mm", "camera_roll_deg"});
      r.axis_dy_per_mm = GetNumber(m, p, "axis_dy_per_mm", 0.0, -0.2, 0.2);
      r.axis_dz_per_mm = GetNumber(m, p, "axis_dz_per_mm", 0.0, -0.2, 0.2);
      r.camera_roll_deg = GetNumber(m, p, "camera_roll_deg", 0.0, -10, 10);
    }
  }
  if (root.contains("sensor")) {
    const Json& j = root.at("sensor");
    const std::string p = "sensor";
    CheckKeys(j, p,
              {"electrons_per_exposure", "full_well_e", "read_noise_e",
               "shot_noise", "response", "raw_response", "raw_white_level"});
    SensorModel& m = s.sensor;
    m.electrons_per_exposure = GetPositive(j, p, "electrons_per_exposure",
                                           m.electrons_per_exposure, 1e9);
    m.full_well_e = GetPositive(j, p, "full_well_e", m.full_well_e, 1e9);
    m.read_noise_e = GetNumber(j, p, "read_noise_e", m.read_noise_e, 0, 1e6);
    m.shot_noise = GetBool(j, p, "shot_noise", m.shot_noise);
    m.response = ParseResponse(j, p, "response", m.response);
    m.raw_response = ParseResponse(j, p, "raw_response", m.raw_response);
    m.raw_white_level =
        GetInt(j, p, "raw_white_level", m.raw_white_level, 255, 65535);
  }
  s.ambient_lux = GetColor(root, "", "ambient_lux", s.ambient_lux, 0, 1e9);

  if (const Json* objects = GetArray(root, "", "objects", kMaxObjects)) {
    std::set<std::string> names;
    for (size_t i = 0; i < objects->size(); ++i) {
      const std::string p = absl::StrCat("objects[", i, "]");
      s.objects.push_back(ParseObject((*objects)[i], p));
      const std::string& name = s.objects.back().name;
      if (!name.empty() && !names.insert(name).second) {
        Fail(p + ".name",
             absl::StrCat("duplicate object name ", QuoteInput(name)));
      }
    }
  }
  if (root.contains("calibration_board")) {
    const Json& j = root.at("calibration_board");
    const std::string p = "calibration_board";
    CheckKeys(j, p, {"objects", "poses"});
    const Json* names = GetArray(j, p, "objects", kMaxObjects);
    if (names == nullptr || names->empty()) {
      Fail(p + ".objects", "expected a non-empty array of object names");
    }
    for (size_t i = 0; i < names->size(); ++i) {
      const std::string np = absl::StrCat(p, ".objects[", i, "]");
      const Json& name = (*names)[i];
      if (!name.is_string()) Fail(np, "expected an object name");
      const int index = s.FindObject(name.get<std::string>());
      if (index < 0) {
        Fail(np, absl::StrCat("no object is called ",
                              QuoteInput(name.get<std::string>())));
      }
      if (s.objects[index].shape != ShapeKind::kPlane) {
        Fail(np, "only planes can be board objects");
      }
      s.calibration_board.objects.push_back(index);
    }
    const Json* board_poses = GetArray(j, p, "poses", kMaxBoardPoses);
    if (board_poses == nullptr || board_poses->empty()) {
      Fail(p + ".poses", "expected a non-empty array of poses");
    }
    const Json& poses = *board_poses;
    for (size_t i = 0; i < poses.size(); ++i) {
      const std::string pp = absl::StrCat(p, ".poses[", i, "]");
      CheckKeys(poses[i], pp, {"offset_mm", "rotation_deg"});
      BoardPose pose;
      pose.offset = GetVec3(poses[i], pp, "offset_mm", Vec3());
      const Vec3 deg = GetVec3(poses[i], pp, "rotation_deg", Vec3());
      for (int k = 0; k < 3; ++k) {
        if (std::abs(deg[k]) > 80) {
          Fail(pp + ".rotation_deg", "angles must be in [-80, 80]");
        }
      }
      pose.rotation = RotationFromEulerDeg(deg);
      s.calibration_board.poses.push_back(pose);
    }
  }
  if (const Json* lights = GetArray(root, "", "lights", kMaxLights)) {
    for (size_t i = 0; i < lights->size(); ++i) {
      const std::string p = absl::StrCat("lights[", i, "]");
      const Json& j = (*lights)[i];
      CheckKeys(j, p, {"type", "position_mm", "intensity_cd", "color"});
      std::string type = GetString(j, p, "type", "point");
      if (type != "point") Fail(p + ".type", "only \"point\" lights exist");
      if (!j.contains("position_mm")) Fail(p + ".position_mm", "missing");
      PointLight l;
      l.position = GetVec3(j, p, "position_mm", l.position);
      l.intensity_cd = GetNumber(j, p, "intensity_cd", l.intensity_cd, 0, 1e12);
      l.color = GetColor(j, p, "color", l.color, 0, 1e3);
      s.lights.push_back(l);
    }
  }
  if (root.contains("projector")) {
    const Json& j = root.at("projector");
    const std::string p = "projector";
    CheckKeys(j, p,
              {"position_mm", "look_at_mm", "width", "height", "fov_deg",
               "max_intensity_cd", "black_level", "gamma", "blur_px",
               "latency_s", "refresh_hz"});
    ProjectorModel& pr = s.projector;
    pr.present = true;
    pr.position = GetVec3(j, p, "position_mm", pr.position);
    Vec3 look = GetVec3(j, p, "look_at_mm", pr.position + Vec3(0, 0, 1000));
    pr.rotation = LookAt(pr.position, look, p + ".look_at_mm");
    pr.width = GetInt(j, p, "width", pr.width, 2, kMaxProjectorSide);
    pr.height = GetInt(j, p, "height", pr.height, 2, kMaxProjectorSide);
    Check(CheckedMultiply("projector pixels (width x height)", pr.width,
                          pr.height, kMaxProjectorPixels)
              .status());
    pr.fov_deg = GetNumber(j, p, "fov_deg", pr.fov_deg, 1, 170);
    pr.max_intensity_cd =
        GetNumber(j, p, "max_intensity_cd", pr.max_intensity_cd, 0, 1e12);
    pr.black_level = GetNumber(j, p, "black_level", pr.black_level, 0, 1);
    pr.gamma = GetNumber(j, p, "gamma", pr.gamma, 0.1, 10);
    pr.blur_px = GetNumber(j, p, "blur_px", pr.blur_px, 0, 100);
    pr.latency_s = GetNumber(j, p, "latency_s", pr.latency_s, 0, 10);
    pr.refresh_hz = GetNumber(j, p, "refresh_hz", pr.refresh_hz, 1, 1000);
  }
  if (root.contains("timing")) {
    const Json& j = root.at("timing");
    const std::string p = "timing";
    CheckKeys(j, p,
              {"scale", "readout_s", "transfer_s", "stage_speed_mm_s",
               "stage_accel_mm_s2", "projector_settle_s"});
    TimingModel& t = s.timing;
    t.scale = GetNumber(j, p, "scale", t.scale, 0, 1000);
    t.readout_s = GetNumber(j, p, "readout_s", t.readout_s, 0, 3600);
    t.transfer_s = GetNumber(j, p, "transfer_s", t.transfer_s, 0, 3600);
    // A crawling stage would sleep for ages in a scaled simulation.
    t.stage_speed_mm_s =
        GetNumber(j, p, "stage_speed_mm_s", t.stage_speed_mm_s, 1e-3, 1e6);
    t.stage_accel_mm_s2 =
        GetNumber(j, p, "stage_accel_mm_s2", t.stage_accel_mm_s2, 1e-3, 1e7);
    t.projector_settle_s =
        GetNumber(j, p, "projector_settle_s", t.projector_settle_s, 0, 3600);
  }
  if (root.contains("faults")) {
    const Json& j = root.at("faults");
    CheckKeys(j, "faults", {"camera", "stage", "projector"});
    if (j.contains("camera")) {
      const Json& c = j.at("camera");
      const std::string p = "faults.camera";
      CheckKeys(c, p,
                {"busy_first_calls", "timeout", "disconnect",
                 "disconnect_failed_reopens", "absent_until_file", "corrupt",
                 "previous_file", "wrong_exposure", "wrong_depth",
                 "card_target", "hold", "hold_fifo", "low_battery", "ptpip"});
      s.camera_faults.busy_first_calls =
          GetInt(c, p, "busy_first_calls", 0, 0, 1000000);
      s.camera_faults.timeout = ParseTrigger(c, p, "timeout");
      s.camera_faults.disconnect = ParseTrigger(c, p, "disconnect");
      s.camera_faults.disconnect_failed_reopens =
          GetInt(c, p, "disconnect_failed_reopens", -1, -1, 1000000);
      s.camera_faults.absent_until_file =
          GetString(c, p, "absent_until_file", "", io::kMaxRelativePathBytes);
      s.camera_faults.corrupt = ParseTrigger(c, p, "corrupt");
      s.camera_faults.previous_file = ParseTrigger(c, p, "previous_file");
      s.camera_faults.wrong_exposure = ParseTrigger(c, p, "wrong_exposure");
      s.camera_faults.wrong_depth = ParseTrigger(c, p, "wrong_depth");
      s.camera_faults.card_target = ParseTrigger(c, p, "card_target");
      s.camera_faults.hold = ParseTrigger(c, p, "hold");
      s.camera_faults.hold_fifo =
          GetString(c, p, "hold_fifo", "", io::kMaxRelativePathBytes);
      if (s.camera_faults.hold.enabled() && s.camera_faults.hold_fifo.empty()) {
        Fail(p + ".hold_fifo", "required with hold (the FIFO it waits on)");
      }
      s.camera_faults.low_battery =
          ParseWindow(c, p, "low_battery", {"percent"});
      if (c.contains("low_battery")) {
        s.camera_faults.low_battery_percent =
            GetInt(c.at("low_battery"), p + ".low_battery", "percent",
                   s.camera_faults.low_battery_percent, 0, 100);
      }
      if (c.contains("ptpip")) {
        const Json& n = c.at("ptpip");
        const std::string q = p + ".ptpip";
        CheckKeys(n, q,
                  {"drop_in_transfer", "slow_transfer", "slow_transfer_s",
                   "store_full"});
        CameraFaults::PtpIp& f = s.camera_faults.ptpip;
        f.drop_in_transfer = ParseTrigger(n, q, "drop_in_transfer");
        f.slow_transfer = ParseTrigger(n, q, "slow_transfer");
        f.slow_transfer_s =
            GetNumber(n, q, "slow_transfer_s", f.slow_transfer_s, 0, 3600);
        f.store_full = ParseTrigger(n, q, "store_full");
      }
    }
    if (j.contains("stage")) {
      const Json& c = j.at("stage");
      const std::string p = "faults.stage";
      CheckKeys(
          c, p,
          {"silent", "garbled", "stall", "warning_flag", "warning_window"});
      s.stage_faults.silent = ParseTrigger(c, p, "silent");
      s.stage_faults.garbled = ParseTrigger(c, p, "garbled");
      s.stage_faults.stall = ParseTrigger(c, p, "stall");
      s.stage_faults.warning_flag =
          GetWarningFlag(c, p, "warning_flag", "--", /*none_allowed=*/true);
      s.stage_faults.warning_window =
          ParseWindow(c, p, "warning_window", {"flag"});
      if (c.contains("warning_window")) {
        s.stage_faults.warning_window_flag = GetWarningFlag(
            c.at("warning_window"), p + ".warning_window", "flag",
            s.stage_faults.warning_window_flag, /*none_allowed=*/false);
      }
    }
    if (j.contains("projector")) {
      const Json& c = j.at("projector");
      const std::string p = "faults.projector";
      CheckKeys(c, p, {"lost"});
      s.projector_faults.lost = ParseWindow(c, p, "lost");
    }
  }
  return s;
}

}  // namespace

absl::StatusOr<Scene> WithBoardPose(const Scene& scene, int pose) {
  const CalibrationBoard& board = scene.calibration_board;
  if (board.poses.empty() || board.objects.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "scene \"", scene.name, "\" has no calibration_board poses"));
  }
  if (pose < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("board pose ", pose, " is negative"));
  }
  const BoardPose& p = board.poses[pose % board.poses.size()];
  Scene out = scene;
  const Vec3 pivot = scene.objects[board.objects.front()].center;
  for (int index : board.objects) {
    const Object& from = scene.objects[index];
    Object& to = out.objects[index];
    to.center = pivot + p.offset + p.rotation * (from.center - pivot);
    to.normal = p.rotation * from.normal;
    to.u_axis = p.rotation * from.u_axis;
  }
  return out;
}

double ProjectorModel::focal_px() const {
  return (width / 2.0) / std::tan(fov_deg * kPi / 360.0);
}

Vec3 RigModel::StageAxis() const {
  Vec3 a(1.0, axis_dy_per_mm, axis_dz_per_mm);
  return rotation * (a / cv::norm(a));
}

Mat3 RigModel::CameraRotation() const {
  const double r = camera_roll_deg * kPi / 180.0;
  Mat3 roll(std::cos(r), -std::sin(r), 0, std::sin(r), std::cos(r), 0, 0, 0, 1);
  return rotation * roll;
}

Vec3 RigModel::CameraCenter(double stage_mm) const {
  return origin + stage_mm * StageAxis();
}

bool RigModel::IsIdeal() const {
  return axis_dy_per_mm == 0 && axis_dz_per_mm == 0 && camera_roll_deg == 0;
}

double ResponseCurve::Evaluate(double x) const {
  x = std::clamp(x, 0.0, 1.0);
  switch (kind) {
    case ResponseKind::kLinear:
      return x;
    case ResponseKind::kGamma:
      return std::pow(x, 1.0 / gamma);
    case ResponseKind::kSCurve: {
      double y = std::pow(x, 1.0 / gamma);
      if (y <= 0) return 0.0;
      if (y >= 1) return 1.0;
      double a = std::pow(y, contrast), b = std::pow(1.0 - y, contrast);
      return a / (a + b);
    }
  }
  return x;
}

double ResponseCurve::Inverse(double y) const {
  y = std::clamp(y, 0.0, 1.0);
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    double mid = 0.5 * (lo + hi);
    (Evaluate(mid) < y ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double TimingModel::CaptureSeconds(double exposure_s) const {
  return exposure_s + readout_s + transfer_s;
}

double TimingModel::MoveSeconds(double distance_mm) const {
  const double d = std::abs(distance_mm), v = stage_speed_mm_s,
               a = stage_accel_mm_s2;
  if (d <= 0) return 0.0;
  const double d_ramp = v * v / a;  // accelerate + decelerate to full speed
  if (d < d_ramp) return 2.0 * std::sqrt(d / a);  // triangular profile
  return 2.0 * v / a + (d - d_ramp) / v;
}

double TimingModel::MoveProgressMm(double distance_mm, double t) const {
  const double d = std::abs(distance_mm), v = stage_speed_mm_s,
               a = stage_accel_mm_s2;
  const double total = MoveSeconds(d);
  if (t <= 0) return 0.0;
  if (t >= total) return d;
  const double d_ramp = v * v / a;
  if (d < d_ramp) {  // triangular
    const double th = total / 2;
    if (t <= th) return 0.5 * a * t * t;
    const double r = total - t;
    return d - 0.5 * a * r * r;
  }
  const double ta = v / a;
  if (t <= ta) return 0.5 * a * t * t;
  if (t <= total - ta) return 0.5 * a * ta * ta + v * (t - ta);
  const double r = total - t;
  return d - 0.5 * a * r * r;
}

int Scene::FindObject(absl::string_view name) const {
  for (size_t i = 0; i < objects.size(); ++i) {
    if (objects[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

absl::StatusOr<Scene> ParseScene(absl::string_view json_text) {
  if (json_text.size() > kMaxSceneBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("scene: ", json_text.size(),
                     " bytes, more than the limit of ", kMaxSceneBytes));
  }
  Json root;
  try {
    root = Json::parse(json_text.begin(), json_text.end());
  } catch (const Json::exception& e) {
    // Not only parse_error: a number beyond double is out_of_range.
    return absl::InvalidArgumentError(absl::StrCat(
        "scene is not valid JSON: ", io::BoundedJsonError(e.what())));
  }
  try {
    return ParseSceneJson(root);
  } catch (const FieldError& e) {
    return absl::InvalidArgumentError(absl::StrCat("scene: ", e.what()));
  } catch (const Json::exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("scene: ", e.what()));
  }
}

absl::StatusOr<Scene> LoadSceneFile(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(const std::string text,
                   io::ReadFileBytes(path, kMaxSceneBytes, "scene file"));
  return io::WithSource(path.string(), ParseScene(text));
}

std::vector<std::string> BundledSceneNames() {
  std::vector<std::string> names;
  for (const BundledScene& s : BundledScenes()) names.emplace_back(s.name);
  return names;
}

absl::StatusOr<Scene> LoadBundledScene(absl::string_view name) {
  for (const BundledScene& s : BundledScenes()) {
    if (s.name == name) {
      absl::StatusOr<Scene> scene = ParseScene(s.json);
      if (!scene.ok()) {
        return absl::InternalError(absl::StrCat(
            "bundled scene ", name, " is broken: ", scene.status().message()));
      }
      return scene;
    }
  }
  return absl::NotFoundError(absl::StrCat(
      "no bundled scene \"", name,
      "\" (have: ", absl::StrJoin(BundledSceneNames(), ", "), ")"));
}

void ScaleCamera(Scene& scene, int width) {
  CameraIntrinsics& c = scene.camera;
  const double k = static_cast<double>(width) / c.width;
  c.height = static_cast<int>(std::lround(c.height * k));
  c.width = width;
  c.fx *= k;
  c.fy *= k;
  c.cx = (c.width - 1) / 2.0;
  c.cy = (c.height - 1) / 2.0;
}

absl::StatusOr<Scene> LoadScene(absl::string_view name_or_path) {
  for (const BundledScene& s : BundledScenes()) {
    if (s.name == name_or_path) return LoadBundledScene(name_or_path);
  }
  return LoadSceneFile(std::filesystem::path(std::string(name_or_path)));
}

}  // namespace hdrstereo::sim
