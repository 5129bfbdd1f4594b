// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "hardware/sim/bundled_scenes.h"

namespace hdrstereo::sim {
namespace {

using Json = nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

// Thrown inside the parser only; ParseScene turns it into a Status.
struct FieldError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw FieldError(absl::StrCat(path, ": ", what));
}

std::string Join(const std::string& path, const std::string& key) {
  return path.empty() ? key : absl::StrCat(path, ".", key);
}

void CheckKeys(const Json& j, const std::string& path,
               const std::set<std::string>& allowed) {
  if (!j.is_object()) Fail(path.empty() ? "scene" : path, "expected an object");
  for (const auto& [key, value] : j.items()) {
    if (!allowed.count(key)) {
      Fail(Join(path, key), absl::StrCat("unknown field (allowed: ",
                                         absl::StrJoin(allowed, ", "), ")"));
    }
  }
}

double Number(const Json& j, const std::string& path) {
  if (!j.is_number()) Fail(path, "expected a number");
  double v = j.get<double>();
  if (!std::isfinite(v)) Fail(path, "expected a finite number");
  return v;
}

// Reads obj[key] if present; checks lo <= v <= hi.
double GetNumber(const Json& obj, const std::string& path,
                 const std::string& key, double fallback, double lo = -1e300,
                 double hi = 1e300) {
  if (!obj.contains(key)) return fallback;
  const std::string p = Join(path, key);
  double v = Number(obj.at(key), p);
  if (v < lo || v > hi) {
    Fail(p, absl::StrCat("must be in [", lo, ", ", hi, "], got ", v));
  }
  return v;
}

double GetPositive(const Json& obj, const std::string& path,
                   const std::string& key, double fallback) {
  double v = GetNumber(obj, path, key, fallback);
  if (!(v > 0)) Fail(Join(path, key), absl::StrCat("must be > 0, got ", v));
  return v;
}

int GetInt(const Json& obj, const std::string& path, const std::string& key,
           int fallback, int lo, int hi) {
  if (!obj.contains(key)) return fallback;
  const std::string p = Join(path, key);
  const Json& j = obj.at(key);
  if (!j.is_number_integer()) Fail(p, "expected an integer");
  int64_t v = j.get<int64_t>();
  if (v < lo || v > hi) {
    Fail(p, absl::StrCat("must be in [", lo, ", ", hi, "], got ", v));
  }
  return static_cast<int>(v);
}

bool GetBool(const Json& obj, const std::string& path, const std::string& key,
             bool fallback) {
  if (!obj.contains(key)) return fallback;
  if (!obj.at(key).is_boolean()) Fail(Join(path, key), "expected true/false");
  return obj.at(key).get<bool>();
}

std::string GetString(const Json& obj, const std::string& path,
                      const std::string& key, const std::string& fallback) {
  if (!obj.contains(key)) return fallback;
  if (!obj.at(key).is_string()) Fail(Join(path, key), "expected a string");
  return obj.at(key).get<std::string>();
}

Vec3 ToVec3(const Json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) Fail(path, "expected 3 numbers");
  return Vec3(Number(j[0], path + "[0]"), Number(j[1], path + "[1]"),
              Number(j[2], path + "[2]"));
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
  if (j.contains("calls")) {
    const Json& calls = j.at("calls");
    if (!calls.is_array()) Fail(p + ".calls", "expected an array of integers");
    for (size_t i = 0; i < calls.size(); ++i) {
      if (!calls[i].is_number_integer() || calls[i].get<int64_t>() < 1) {
        Fail(absl::StrCat(p, ".calls[", i, "]"), "expected a call number >= 1");
      }
      t.calls.push_back(static_cast<int>(calls[i].get<int64_t>()));
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
    Fail(p + ".kind",
         "expected linear, gamma or s_curve, got \"" + kind + "\"");
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
           "expected uniform, checker or noise, got \"" + kind + "\"");
    }
    m.texture.second_albedo =
        GetColor(t, tp, "second_albedo", m.texture.second_albedo, 0.0, 1.0);
    m.texture.square_mm = GetPositive(t, tp, "square_mm", m.texture.square_mm);
    m.texture.scale_mm = GetPositive(t, tp, "scale_mm", m.texture.scale_mm);
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
    o.radius = GetPositive(j, p, "radius_mm", o.radius);
  } else {
    Fail(p + ".type", "expected plane, box or sphere, got \"" + type + "\"");
  }
  return o;
}

Scene ParseSceneJson(const Json& root) {
  CheckKeys(
      root, "",
      {"name", "description", "seed", "camera", "rig", "sensor", "ambient_lux",
       "objects", "lights", "projector", "timing", "faults"});
  Scene s;
  s.name = GetString(root, "", "name", "");
  s.description = GetString(root, "", "description", "");
  s.seed = static_cast<uint64_t>(GetInt(root, "", "seed", 1, 0, 1 << 30));

  if (root.contains("camera")) {
    const Json& j = root.at("camera");
    CheckKeys(j, "camera", {"width", "height", "fx", "fy", "cx", "cy"});
    CameraIntrinsics& c = s.camera;
    c.width = GetInt(j, "camera", "width", c.width, 8, 20000);
    c.height = GetInt(j, "camera", "height", c.height, 8, 20000);
    c.fx = GetPositive(j, "camera", "fx", c.fx);
    c.fy = GetPositive(j, "camera", "fy", c.fx);
    c.cx = GetNumber(j, "camera", "cx", (c.width - 1) / 2.0);
    c.cy = GetNumber(j, "camera", "cy", (c.height - 1) / 2.0);
  }
  if (root.contains("rig")) {
    const Json& j = root.at("rig");
    CheckKeys(j, "rig",
              {"origin_mm", "rotation_deg", "travel_mm", "misalignment"});
    RigModel& r = s.rig;
    r.origin = GetVec3(j, "rig", "origin_mm", r.origin);
    r.rotation =
        RotationFromEulerDeg(GetVec3(j, "rig", "rotation_deg", Vec3()));
    r.travel_mm = GetPositive(j, "rig", "travel_mm", r.travel_mm);
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
    m.electrons_per_exposure =
        GetPositive(j, p, "electrons_per_exposure", m.electrons_per_exposure);
    m.full_well_e = GetPositive(j, p, "full_well_e", m.full_well_e);
    m.read_noise_e = GetNumber(j, p, "read_noise_e", m.read_noise_e, 0, 1e6);
    m.shot_noise = GetBool(j, p, "shot_noise", m.shot_noise);
    m.response = ParseResponse(j, p, "response", m.response);
    m.raw_response = ParseResponse(j, p, "raw_response", m.raw_response);
    m.raw_white_level =
        GetInt(j, p, "raw_white_level", m.raw_white_level, 255, 65535);
  }
  s.ambient_lux = GetColor(root, "", "ambient_lux", s.ambient_lux, 0, 1e9);

  if (root.contains("objects")) {
    const Json& objects = root.at("objects");
    if (!objects.is_array()) Fail("objects", "expected an array");
    std::set<std::string> names;
    for (size_t i = 0; i < objects.size(); ++i) {
      const std::string p = absl::StrCat("objects[", i, "]");
      s.objects.push_back(ParseObject(objects[i], p));
      const std::string& name = s.objects.back().name;
      if (!name.empty() && !names.insert(name).second) {
        Fail(p + ".name", "duplicate object name \"" + name + "\"");
      }
    }
  }
  if (s.objects.size() > 65000) Fail("objects", "too many objects");
  if (root.contains("lights")) {
    const Json& lights = root.at("lights");
    if (!lights.is_array()) Fail("lights", "expected an array");
    for (size_t i = 0; i < lights.size(); ++i) {
      const std::string p = absl::StrCat("lights[", i, "]");
      const Json& j = lights[i];
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
    pr.width = GetInt(j, p, "width", pr.width, 2, 16384);
    pr.height = GetInt(j, p, "height", pr.height, 2, 16384);
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
    t.stage_speed_mm_s =
        GetPositive(j, p, "stage_speed_mm_s", t.stage_speed_mm_s);
    t.stage_accel_mm_s2 =
        GetPositive(j, p, "stage_accel_mm_s2", t.stage_accel_mm_s2);
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
                 "previous_file", "wrong_exposure", "card_target", "hold",
                 "hold_fifo", "low_battery"});
      s.camera_faults.busy_first_calls =
          GetInt(c, p, "busy_first_calls", 0, 0, 1000000);
      s.camera_faults.timeout = ParseTrigger(c, p, "timeout");
      s.camera_faults.disconnect = ParseTrigger(c, p, "disconnect");
      s.camera_faults.disconnect_failed_reopens =
          GetInt(c, p, "disconnect_failed_reopens", -1, -1, 1000000);
      s.camera_faults.absent_until_file =
          GetString(c, p, "absent_until_file", "");
      s.camera_faults.corrupt = ParseTrigger(c, p, "corrupt");
      s.camera_faults.previous_file = ParseTrigger(c, p, "previous_file");
      s.camera_faults.wrong_exposure = ParseTrigger(c, p, "wrong_exposure");
      s.camera_faults.card_target = ParseTrigger(c, p, "card_target");
      s.camera_faults.hold = ParseTrigger(c, p, "hold");
      s.camera_faults.hold_fifo = GetString(c, p, "hold_fifo", "");
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
  Json root;
  try {
    root = Json::parse(json_text.begin(), json_text.end());
  } catch (const Json::parse_error& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("scene is not valid JSON: ", e.what()));
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
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::NotFoundError(
        absl::StrCat("cannot read scene file ", path.string()));
  }
  std::stringstream buffer;
  buffer << in.rdbuf();
  absl::StatusOr<Scene> scene = ParseScene(buffer.str());
  if (!scene.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": ", scene.status().message()));
  }
  return scene;
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
