// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/capture_layout.h"

#include <cmath>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace hdrstereo::io {
namespace {

// "03" -> 3; nullopt unless 1 to 3 digits.
std::optional<int> SmallNumber(absl::string_view digits) {
  if (digits.empty() || digits.size() > 3) return std::nullopt;
  int value = 0;
  for (char c : digits) {
    if (!absl::ascii_isdigit(c)) return std::nullopt;
    value = value * 10 + (c - '0');
  }
  return value;
}

// "exp_<tag>" -> seconds.
std::optional<double> ExposureOf(absl::string_view name) {
  if (!absl::ConsumePrefix(&name, "exp_")) return std::nullopt;
  return ParseExposureTag(name);
}

}  // namespace

const char* CaptureKindName(CaptureKind kind) {
  switch (kind) {
    case CaptureKind::kBracketedStereo:
      return "bracketed_stereo";
    case CaptureKind::kStructuredLight:
      return "structured_light";
    case CaptureKind::kCalibration:
      return "calibration";
  }
  return "unknown";
}

absl::StatusOr<CaptureKind> ParseCaptureKind(absl::string_view name) {
  for (CaptureKind k :
       {CaptureKind::kBracketedStereo, CaptureKind::kStructuredLight,
        CaptureKind::kCalibration}) {
    if (name == CaptureKindName(k)) return k;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown capture kind \"", name,
      "\"; known: bracketed_stereo, structured_light, calibration"));
}

const char* FrameRoleName(FrameRole role) {
  switch (role) {
    case FrameRole::kAmbient:
      return "ambient";
    case FrameRole::kStereo:
      return "stereo";
    case FrameRole::kStructuredLight:
      return "structured_light";
    case FrameRole::kCalibration:
      return "calibration";
  }
  return "unknown";
}

absl::StatusOr<FrameRole> ParseFrameRole(absl::string_view name) {
  for (FrameRole r : {FrameRole::kAmbient, FrameRole::kStereo,
                      FrameRole::kStructuredLight, FrameRole::kCalibration}) {
    if (name == FrameRoleName(r)) return r;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown frame role \"", name,
      "\"; known: ambient, stereo, structured_light, calibration"));
}

CaptureKind KindOfRole(FrameRole role) {
  switch (role) {
    case FrameRole::kAmbient:
    case FrameRole::kStereo:
      return CaptureKind::kBracketedStereo;
    case FrameRole::kStructuredLight:
      return CaptureKind::kStructuredLight;
    case FrameRole::kCalibration:
      return CaptureKind::kCalibration;
  }
  return CaptureKind::kBracketedStereo;
}

std::string ViewName(int view_index, int views) {
  if (views == 2) return view_index == 0 ? "left" : "right";
  return absl::StrCat("view", view_index);
}

std::optional<int> ParseViewName(absl::string_view name) {
  if (name == "left") return 0;
  if (name == "right") return 1;
  if (absl::ConsumePrefix(&name, "view")) return SmallNumber(name);
  return std::nullopt;
}

std::string ExposureTag(double seconds) {
  if (seconds < 0.4) {
    const double denominator = 1.0 / seconds;
    if (std::abs(denominator - std::round(denominator)) < 1e-6 * denominator) {
      return absl::StrFormat("1-%.0fs", denominator);
    }
  }
  return absl::StrReplaceAll(absl::StrFormat("%gs", seconds), {{"+", ""}});
}

std::optional<double> ParseExposureTag(absl::string_view tag) {
  if (!absl::ConsumeSuffix(&tag, "s") || tag.empty()) return std::nullopt;
  double value = 0;
  const size_t dash = tag.find('-');
  if (dash != absl::string_view::npos) {
    int num = 0, den = 0;
    if (!absl::SimpleAtoi(tag.substr(0, dash), &num) ||
        !absl::SimpleAtoi(tag.substr(dash + 1), &den) || num <= 0 || den <= 0) {
      return std::nullopt;
    }
    value = static_cast<double>(num) / den;
  } else if (!absl::SimpleAtod(tag, &value)) {
    return std::nullopt;
  }
  if (!std::isfinite(value) || value <= 0) return std::nullopt;
  return value;
}

std::string FrameFileStem(const FrameKey& key) {
  switch (key.role) {
    case FrameRole::kAmbient:
    case FrameRole::kStereo:
      return absl::StrCat("exp_", ExposureTag(key.exposure_s));
    case FrameRole::kStructuredLight:
      return absl::StrCat("sl_", key.pattern, key.inverse ? "_inv" : "",
                          "_exp_", ExposureTag(key.exposure_s));
    case FrameRole::kCalibration:
      return absl::StrFormat("pose_%02d", key.pose);
  }
  return "";
}

std::optional<FrameKey> ParseFrameFileStem(FrameRole role,
                                           absl::string_view stem) {
  FrameKey key;
  key.role = role;
  switch (role) {
    case FrameRole::kAmbient:
    case FrameRole::kStereo: {
      const std::optional<double> e = ExposureOf(stem);
      if (!e) return std::nullopt;
      key.exposure_s = *e;
      return key;
    }
    case FrameRole::kStructuredLight: {
      if (!absl::ConsumePrefix(&stem, "sl_")) return std::nullopt;
      const size_t at = stem.rfind("_exp_");
      if (at == absl::string_view::npos) return std::nullopt;
      const std::optional<double> e = ExposureOf(stem.substr(at + 1));
      if (!e) return std::nullopt;
      key.exposure_s = *e;
      absl::string_view id = stem.substr(0, at);
      if (id == "white" || id == "black") {
        key.pattern = std::string(id);
        return key;
      }
      key.inverse = absl::ConsumeSuffix(&id, "_inv");
      const bool column = absl::ConsumePrefix(&id, "col_b");
      if (!column && !absl::ConsumePrefix(&id, "row_b")) return std::nullopt;
      const std::optional<int> bit = SmallNumber(id);
      if (!bit) return std::nullopt;
      key.pattern = absl::StrFormat("%s_b%02d", column ? "col" : "row", *bit);
      return key;
    }
    case FrameRole::kCalibration: {
      if (!absl::ConsumePrefix(&stem, "pose_")) return std::nullopt;
      const std::optional<int> pose = SmallNumber(stem);
      if (!pose) return std::nullopt;
      key.pose = *pose;
      return key;
    }
  }
  return std::nullopt;
}

std::string CaptureDir(int64_t capture_id) {
  return absl::StrCat(kCapturesDir, "/", capture_id);
}

std::string TruthDir(int64_t capture_id) {
  return absl::StrCat(CaptureDir(capture_id), "/truth");
}

std::string RoleDir(int64_t capture_id, absl::string_view view,
                    FrameRole role) {
  return absl::StrCat(CaptureDir(capture_id), "/", view, "/",
                      FrameRoleName(role));
}

std::string FrameStem(int64_t capture_id, absl::string_view view,
                      const FrameKey& key) {
  return absl::StrCat(RoleDir(capture_id, view, key.role), "/",
                      FrameFileStem(key));
}

absl::StatusOr<FramePath> ParseFramePath(absl::string_view relative_path) {
  const std::vector<absl::string_view> parts =
      absl::StrSplit(relative_path, '/');
  if (parts.size() != 5 || parts[0] != kCapturesDir) {
    return absl::InvalidArgumentError(absl::StrCat(
        relative_path, " is not captures/<id>/<view>/<role>/<file>"));
  }
  FramePath out;
  if (!absl::SimpleAtoi(parts[1], &out.capture_id) || out.capture_id < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        relative_path, ": \"", parts[1], "\" is not a capture id"));
  }
  const std::optional<int> view = ParseViewName(parts[2]);
  if (!view) {
    return absl::InvalidArgumentError(
        absl::StrCat(relative_path, ": \"", parts[2],
                     "\" is not a view (left, right, view<i>)"));
  }
  out.view = std::string(parts[2]);
  out.view_index = *view;
  absl::StatusOr<FrameRole> role = ParseFrameRole(parts[3]);
  if (!role.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(relative_path, ": ", role.status().message()));
  }
  const absl::string_view file = parts[4];
  const size_t dot = file.rfind('.');
  const absl::string_view stem =
      dot == absl::string_view::npos ? file : file.substr(0, dot);
  std::optional<FrameKey> key = ParseFrameFileStem(*role, stem);
  if (!key) {
    return absl::InvalidArgumentError(absl::StrCat(
        relative_path, ": \"", file, "\" is not a ", parts[3], " frame name"));
  }
  out.key = std::move(*key);
  return out;
}

}  // namespace hdrstereo::io
