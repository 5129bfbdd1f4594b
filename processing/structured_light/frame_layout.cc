// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/frame_layout.h"

#include <algorithm>
#include <optional>
#include <set>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/strip.h"
#include "nlohmann/json.hpp"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/image.h"
#include "processing/io/json_input.h"
#include "processing/io/relative_path.h"
#include "processing/structured_light/gray_code.h"

namespace hdrstereo::structured_light {
namespace {

using nlohmann::json;

constexpr char kFormat[] = "hdrstereo-sl-layout-1";
// A layout file is a page of JSON (the example above is 500 bytes).
constexpr size_t kMaxLayoutBytes = 1 << 20;
// A path template is one line; its expansion is checked against PATH_MAX.
constexpr size_t kMaxFilesBytes = 1024;
// {frame:N}: frame numbers have at most 2 digits (kMaxLayoutFrames).
constexpr int kMaxFrameDigits = 9;
constexpr int kMaxViews = 16;
constexpr size_t kMaxViewNameBytes = 64;

absl::Status Bad(absl::string_view key, absl::string_view why) {
  return absl::InvalidArgumentError(
      absl::StrCat("structured-light layout: ", key, ": ", why));
}

absl::Status BadFiles(absl::string_view files, absl::string_view why) {
  return Bad("files", absl::StrCat(QuoteInput(files), " ", why));
}

// A view's name goes into file names: letters, digits, '-' and '_' only.
absl::Status CheckViewName(absl::string_view view) {
  if (view.empty() || view.size() > kMaxViewNameBytes ||
      !std::all_of(view.begin(), view.end(), [](char c) {
        return absl::ascii_isalnum(c) || c == '-' || c == '_';
      })) {
    return Bad(
        "views",
        absl::StrCat(QuoteInput(view), " is not a view name (1 to ",
                     kMaxViewNameBytes, " letters, digits, '-' or '_')"));
  }
  return absl::OkStatus();
}

// The zero-padding width of a {frame...} placeholder; `name` is what is
// between its braces.
absl::StatusOr<int> FrameWidth(absl::string_view files,
                               absl::string_view name) {
  if (name == "frame") return 0;
  absl::string_view digits = name;
  int64_t width = 0;
  if (!absl::ConsumePrefix(&digits, "frame:") || digits.empty() ||
      !std::all_of(digits.begin(), digits.end(), absl::ascii_isdigit)) {
    return BadFiles(
        files, absl::StrCat("has the placeholder ",
                            QuoteInput(absl::StrCat("{", name, "}")),
                            "; allowed are {frame}, {frame:N} and {view}"));
  }
  if (!absl::SimpleAtoi(digits, &width) || width < 1 ||
      width > kMaxFrameDigits) {
    return BadFiles(
        files,
        absl::StrCat("pads frame numbers to ", QuoteInput(digits),
                     " digits; the limit is [1, ", kMaxFrameDigits, "]"));
  }
  return static_cast<int>(width);
}

// `files` with its placeholders replaced. INVALID_ARGUMENT naming "files"
// for an unknown placeholder, a brace without its partner or no {frame}.
absl::StatusOr<std::string> ExpandFiles(absl::string_view files, int frame,
                                        absl::string_view view) {
  if (files.size() > kMaxFilesBytes) {
    return BadFiles(files, absl::StrCat("is longer than the limit of ",
                                        kMaxFilesBytes, " bytes"));
  }
  std::string out;
  bool has_frame = false;
  for (size_t i = 0; i < files.size();) {
    if (files[i] == '}') return BadFiles(files, "has a '}' without its '{'");
    if (files[i] != '{') {
      out += files[i++];
      continue;
    }
    const size_t close = files.find('}', i);
    if (close == absl::string_view::npos) {
      return BadFiles(files, "has a '{' without its '}'");
    }
    const absl::string_view name = files.substr(i + 1, close - i - 1);
    i = close + 1;
    if (name == "view") {
      absl::StrAppend(&out, view);
      continue;
    }
    ASSIGN_OR_RETURN(const int width, FrameWidth(files, name));
    absl::StrAppendFormat(&out, "%0*d", width, frame);
    has_frame = true;
  }
  if (!has_frame) {
    return BadFiles(files, "has no {frame} (a path with {frame} and {view})");
  }
  return out;
}

absl::StatusOr<int> Int(const json& object, const std::string& key,
                        const std::string& path, int min, int max,
                        std::optional<int> fallback = std::nullopt) {
  if (!object.contains(key)) {
    if (fallback.has_value()) return *fallback;
    return Bad(path, "missing");
  }
  const absl::StatusOr<int64_t> v =
      io::JsonIntInRange(object[key], path, min, max);
  if (!v.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("structured-light layout: ", v.status().message()));
  }
  return static_cast<int>(*v);
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
  ASSIGN_OR_RETURN(code.first_frame, Int(o, "first_frame", key + ".first_frame",
                                         0, kMaxLayoutFrames));
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

absl::StatusOr<std::string> FrameLayout::FileName(
    int frame, absl::string_view view) const {
  if (frame < 0 || frame > kMaxLayoutFrames) {
    return Bad("frame",
               absl::StrCat(frame, " is outside [0, ", kMaxLayoutFrames, "]"));
  }
  RETURN_IF_ERROR(CheckViewName(view));
  ASSIGN_OR_RETURN(std::string name, ExpandFiles(files, frame, view));
  if (absl::Status s = io::ValidateRelativePath(name); !s.ok()) {
    return Bad("files", absl::StrCat(QuoteInput(files), ": ", s.message(),
                                     " (frames are inside the capture "
                                     "folder)"));
  }
  return name;
}

absl::StatusOr<FrameLayout> ParseFrameLayout(absl::string_view text) {
  if (text.size() > kMaxLayoutBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("structured-light layout: ", text.size(),
                     " bytes, more than the limit of ", kMaxLayoutBytes));
  }
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("structured-light layout is not JSON: ",
                     io::BoundedJsonError(e.what())));
  }
  if (!root.is_object()) return Bad("(top level)", "must be an object");
  if (!root.contains("format") || root["format"] != kFormat) {
    return Bad("format", absl::StrCat("must be \"", kFormat, "\""));
  }
  FrameLayout layout;
  if (!root.contains("projector") || !root["projector"].is_object()) {
    return Bad("projector", "missing ({\"width\": W, \"height\": H})");
  }
  ASSIGN_OR_RETURN(int width, Int(root["projector"], "width", "projector.width",
                                  1, kMaxProjectorSide));
  ASSIGN_OR_RETURN(int height, Int(root["projector"], "height",
                                   "projector.height", 1, kMaxProjectorSide));
  layout.projector_size = cv::Size(width, height);
  if (!root.contains("files")) {
    return Bad("files", "missing (a path with {frame} and {view})");
  }
  if (!root["files"].is_string()) {
    return Bad("files", "must be a string (a path with {frame} and {view})");
  }
  layout.files = root["files"].get<std::string>();
  if (!root.contains("views") || !root["views"].is_array() ||
      root["views"].empty()) {
    return Bad("views", "missing (e.g. [\"left\", \"right\"])");
  }
  if (root["views"].size() > kMaxViews) {
    return Bad("views",
               absl::StrCat(root["views"].size(),
                            " views, more than the limit of ", kMaxViews));
  }
  for (const json& v : root["views"]) {
    if (!v.is_string()) return Bad("views", "must be names (strings)");
    layout.views.push_back(v.get<std::string>());
    // Checks the name and the file names the template gives for it.
    RETURN_IF_ERROR(layout.FileName(0, layout.views.back()).status());
  }
  ASSIGN_OR_RETURN(layout.white,
                   Int(root, "white", "white", 0, kMaxLayoutFrames));
  ASSIGN_OR_RETURN(layout.black,
                   Int(root, "black", "black", 0, kMaxLayoutFrames));
  ASSIGN_OR_RETURN(layout.columns, ParseCode(root, "columns", width));
  ASSIGN_OR_RETURN(layout.rows, ParseCode(root, "rows", height));
  ASSIGN_OR_RETURN(layout.min_bits,
                   Int(root, "min_bits", "min_bits", 0, 16, 0));
  if (layout.min_bits > std::min(layout.columns.bits, layout.rows.bits)) {
    return Bad("min_bits", "is more than the bits of the codes");
  }
  // Every frame plays one role, and the frames are numbered from 0 or 1 up:
  // none is beyond the layout's frame count.
  const int frames = 2 + 2 * (layout.columns.bits + layout.rows.bits);
  const std::string count =
      absl::StrCat("the layout's ", frames, " frames (white, black and ",
                   frames - 2, " code planes, numbered from 0 or 1)");
  for (const auto& [key, frame] :
       {std::pair<const char*, int>{"white", layout.white},
        {"black", layout.black}}) {
    if (frame > frames) {
      return Bad(key, absl::StrCat(frame, " is beyond ", count));
    }
  }
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
        const std::string role =
            absl::StrFormat("bit %d%s", bit, inverse ? " inverse" : "");
        if (frame > frames) {
          return Bad(absl::StrCat(name, ".first_frame"),
                     absl::StrCat(code->first_frame, " puts ", role,
                                  " at frame ", frame, ", beyond ", count));
        }
        if (!used.insert(frame).second) {
          return Bad(name, absl::StrFormat("frame %d (%s) is already used by "
                                           "another pattern",
                                           frame, role));
        }
      }
    }
  }
  // An unpadded {frame} gains digits with the frame number: the names of
  // the last frame are the longest (the views loop checked frame 0).
  for (const std::string& view : layout.views) {
    RETURN_IF_ERROR(layout.FileName(*used.rbegin(), view).status());
  }
  return layout;
}

absl::StatusOr<FrameLayout> LoadFrameLayout(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(
      const std::string text,
      io::ReadFileBytes(path, kMaxLayoutBytes, "structured-light layout"));
  return io::WithSource(path.string(), ParseFrameLayout(text));
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
    ASSIGN_OR_RETURN(const std::string name, layout.FileName(frame, view));
    const std::filesystem::path file = capture_dir / name;
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
