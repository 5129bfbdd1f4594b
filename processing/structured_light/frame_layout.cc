// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/frame_layout.h"

#include <algorithm>
#include <optional>
#include <set>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "nlohmann/json.hpp"
#include "processing/base/status_macros.h"
#include "processing/io/image.h"
#include "processing/structured_light/gray_code.h"

namespace hdrstereo::structured_light {
namespace {

using nlohmann::json;

constexpr char kFormat[] = "hdrstereo-sl-layout-1";

absl::Status Bad(absl::string_view key, absl::string_view why) {
  return absl::InvalidArgumentError(
      absl::StrCat("structured-light layout: ", key, ": ", why));
}

absl::StatusOr<int> Int(const json& object, const std::string& key,
                        const std::string& path, int min, int max,
                        std::optional<int> fallback = std::nullopt) {
  if (!object.contains(key)) {
    if (fallback.has_value()) return *fallback;
    return Bad(path, "missing");
  }
  const json& value = object[key];
  if (!value.is_number_integer()) return Bad(path, "must be an integer");
  const int64_t v = value.get<int64_t>();
  if (v < min || v > max) {
    return Bad(path, absl::StrFormat("%d is outside [%d, %d]", v, min, max));
  }
  return static_cast<int>(v);
}

absl::StatusOr<std::string> Choice(const json& object, const std::string& key,
                                   const std::string& path,
                                   const std::vector<std::string>& allowed) {
  if (!object.contains(key)) return allowed[0];
  const json& value = object[key];
  if (!value.is_string() ||
      std::find(allowed.begin(), allowed.end(), value.get<std::string>()) ==
          allowed.end()) {
    return Bad(path, absl::StrCat("must be one of \"",
                                  absl::StrJoin(allowed, "\", \""), "\""));
  }
  return value.get<std::string>();
}

absl::StatusOr<CodeLayout> ParseCode(const json& root, const std::string& key,
                                     int projector_extent) {
  if (!root.contains(key) || !root[key].is_object()) {
    return Bad(key, "missing (an object with bits, first_frame, ...)");
  }
  const json& o = root[key];
  CodeLayout code;
  ASSIGN_OR_RETURN(code.bits, Int(o, "bits", key + ".bits", 1, 16));
  ASSIGN_OR_RETURN(code.first_frame,
                   Int(o, "first_frame", key + ".first_frame", 0, 100000));
  ASSIGN_OR_RETURN(code.code_offset,
                   Int(o, "code_offset", key + ".code_offset", 0, 65535, 0));
  ASSIGN_OR_RETURN(std::string order, Choice(o, "bit_order", key + ".bit_order",
                                             {"msb-first", "lsb-first"}));
  ASSIGN_OR_RETURN(std::string inverse, Choice(o, "inverse", key + ".inverse",
                                               {"interleaved", "blocked"}));
  code.msb_first = order == "msb-first";
  code.interleaved = inverse == "interleaved";
  if (projector_extent + code.code_offset > (1 << code.bits)) {
    return Bad(
        key + ".bits",
        absl::StrFormat("%d bits cannot code %d projector %s with "
                        "code offset %d (needs %d bits)",
                        code.bits, projector_extent, key, code.code_offset,
                        BitCount(projector_extent + code.code_offset)));
  }
  return code;
}

}  // namespace

int CodeLayout::Frame(int bit, bool inverse) const {
  const int plane = msb_first ? bit : bits - 1 - bit;
  if (interleaved) return first_frame + 2 * plane + (inverse ? 1 : 0);
  return first_frame + plane + (inverse ? bits : 0);
}

std::string FrameLayout::FileName(int frame, const std::string& view) const {
  std::string out;
  for (size_t i = 0; i < files.size();) {
    if (files.compare(i, 6, "{view}") == 0) {
      out += view;
      i += 6;
      continue;
    }
    if (files.compare(i, 6, "{frame") == 0) {
      const size_t close = files.find('}', i);
      int width = 0;
      if (close != std::string::npos && files[i + 6] == ':') {
        absl::SimpleAtoi(files.substr(i + 7, close - i - 7), &width);
      }
      if (close != std::string::npos) {
        out += absl::StrFormat("%0*d", width, frame);
        i = close + 1;
        continue;
      }
    }
    out += files[i++];
  }
  return out;
}

absl::StatusOr<FrameLayout> ParseFrameLayout(absl::string_view text) {
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("structured-light layout is not JSON: ", e.what()));
  }
  if (!root.is_object()) return Bad("(top level)", "must be an object");
  if (!root.contains("format") || root["format"] != kFormat) {
    return Bad("format", absl::StrCat("must be \"", kFormat, "\""));
  }
  FrameLayout layout;
  if (!root.contains("projector") || !root["projector"].is_object()) {
    return Bad("projector", "missing ({\"width\": W, \"height\": H})");
  }
  ASSIGN_OR_RETURN(
      int width, Int(root["projector"], "width", "projector.width", 1, 65535));
  ASSIGN_OR_RETURN(int height, Int(root["projector"], "height",
                                   "projector.height", 1, 65535));
  layout.projector_size = cv::Size(width, height);
  if (!root.contains("files") || !root["files"].is_string() ||
      root["files"].get<std::string>().find("{frame") == std::string::npos) {
    return Bad("files", "missing (a path with {frame} and {view})");
  }
  layout.files = root["files"].get<std::string>();
  if (!root.contains("views") || !root["views"].is_array() ||
      root["views"].empty()) {
    return Bad("views", "missing (e.g. [\"left\", \"right\"])");
  }
  for (const json& v : root["views"]) {
    if (!v.is_string() || v.get<std::string>().empty()) {
      return Bad("views", "must be non-empty names");
    }
    layout.views.push_back(v.get<std::string>());
  }
  ASSIGN_OR_RETURN(layout.white, Int(root, "white", "white", 0, 100000));
  ASSIGN_OR_RETURN(layout.black, Int(root, "black", "black", 0, 100000));
  ASSIGN_OR_RETURN(layout.columns, ParseCode(root, "columns", width));
  ASSIGN_OR_RETURN(layout.rows, ParseCode(root, "rows", height));
  ASSIGN_OR_RETURN(layout.min_bits,
                   Int(root, "min_bits", "min_bits", 0, 16, 0));
  if (layout.min_bits > std::min(layout.columns.bits, layout.rows.bits)) {
    return Bad("min_bits", "is more than the bits of the codes");
  }
  // Every frame plays one role.
  std::set<int> used = {layout.white};
  if (!used.insert(layout.black).second) {
    return Bad("black", "is the same frame as white");
  }
  for (const auto& [name, code] :
       {std::pair<const char*, const CodeLayout*>{"columns", &layout.columns},
        {"rows", &layout.rows}}) {
    for (int bit = 0; bit < code->bits; ++bit) {
      for (bool inverse : {false, true}) {
        const int frame = code->Frame(bit, inverse);
        if (!used.insert(frame).second) {
          return Bad(name,
                     absl::StrFormat("frame %d (bit %d%s) is already used by "
                                     "another pattern",
                                     frame, bit, inverse ? " inverse" : ""));
        }
      }
    }
  }
  return layout;
}

absl::StatusOr<FrameLayout> LoadFrameLayout(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(std::string text, io::ReadFileBytes(path));
  absl::StatusOr<FrameLayout> layout = ParseFrameLayout(text);
  if (!layout.ok()) {
    return absl::Status(
        layout.status().code(),
        absl::StrCat(path.string(), ": ", layout.status().message()));
  }
  return layout;
}

absl::StatusOr<ViewFrames> LoadLayoutView(
    const FrameLayout& layout, const std::filesystem::path& capture_dir,
    const std::string& view) {
  if (std::find(layout.views.begin(), layout.views.end(), view) ==
      layout.views.end()) {
    return absl::InvalidArgumentError(
        absl::StrCat("the layout has no view \"", view,
                     "\" (views: ", absl::StrJoin(layout.views, ", "), ")"));
  }
  ViewFrames out;
  out.projector_size = layout.projector_size;
  out.column_bits = layout.columns.bits;
  out.row_bits = layout.rows.bits;
  out.column_offset = layout.columns.code_offset;
  out.row_offset = layout.rows.code_offset;
  ExposureFrames exposure;
  auto load = [&](int frame) -> absl::Status {
    const std::filesystem::path file =
        capture_dir / layout.FileName(frame, view);
    absl::StatusOr<io::DecodedImage> image = io::DecodeImageFile(file);
    if (!image.ok()) {
      return absl::Status(image.status().code(),
                          absl::StrFormat("%s, frame %d: %s", view, frame,
                                          image.status().message()));
    }
    exposure.frames.push_back(std::move(image->pixels));
    return absl::OkStatus();
  };
  // Decode's order: column planes (each with its inverse), row planes,
  // white, black.
  for (const CodeLayout* code : {&layout.columns, &layout.rows}) {
    for (int bit = 0; bit < code->bits; ++bit) {
      RETURN_IF_ERROR(load(code->Frame(bit, false)));
      RETURN_IF_ERROR(load(code->Frame(bit, true)));
    }
  }
  RETURN_IF_ERROR(load(layout.white));
  RETURN_IF_ERROR(load(layout.black));
  out.exposures.push_back(std::move(exposure));
  return out;
}

}  // namespace hdrstereo::structured_light
