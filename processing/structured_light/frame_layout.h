// SPDX-License-Identifier: GPL-3.0-or-later
//
// Structured-light captures laid out by others: a small JSON file says which
// image file is which pattern, so that a capture made with another lab's
// software decodes without renaming anything. Example (the two-camera
// capture of github.com/ZengZhiK/binocular-gray-code-structured-light):
//
//   {
//     "format": "hdrstereo-sl-layout-1",
//     "projector": {"width": 3840, "height": 2160},
//     "files": "capture/{frame:02}-{view}.png",
//     "views": ["left", "right"],
//     "white": 1,
//     "black": 2,
//     "columns": {"bits": 12, "first_frame": 3, "bit_order": "msb-first",
//                 "inverse": "interleaved", "code_offset": 128},
//     "rows": {"bits": 12, "first_frame": 27, "bit_order": "msb-first",
//              "inverse": "interleaved", "code_offset": 968},
//     "min_bits": 8
//   }
//
// - "files": the path of frame N of a view, relative to the capture folder
//   (no "..", not absolute; at most 1024 bytes); "{frame}" is N
//   ("{frame:02}" zero-padded to 2 digits, at most 9), "{view}" the view's
//   name (1 to 64 letters, digits, '-' or '_'; at most 16 views). No other
//   braces.
// - "white", "black", "first_frame": frame numbers, from 0 or 1 up to the
//   layout's frame count (2 + 2 x the bits of both codes), each used once.
// - "projector": at most kMaxProjectorSide (processing/base/input_limits.h)
//   pixels each way.
// - "columns"/"rows": `bits` bit planes, each projected as a pattern and its
//   inverse, starting at frame `first_frame`. "interleaved": bit, inverse,
//   next bit, ...; "blocked": every bit, then every inverse. "msb-first":
//   the first plane is the most significant bit. The projected code of
//   projector column x is gray(x + code_offset) (row y: gray(y +
//   code_offset)), gray(n) = n ^ (n >> 1).
// - "min_bits" (optional, default every bit): decode a pixel from its most
//   significant bits down to the first bit without usable contrast, and
//   keep it when at least this many bits of each code were read (see
//   DecodeOptions::min_bits).
#ifndef HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_FRAME_LAYOUT_H_
#define HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_FRAME_LAYOUT_H_

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "processing/structured_light/decode.h"

namespace hdrstereo::structured_light {

// The most frames a layout can use: white, black, and 16-bit column and
// row codes whose bits each have an inverse.
inline constexpr int kMaxLayoutFrames = 2 + 2 * 2 * 16;

struct CodeLayout {
  int bits = 0;
  int first_frame = 0;
  bool msb_first = true;
  bool interleaved = true;  // false: "blocked"
  int code_offset = 0;

  // Frame numbers of bit plane `bit` (0 = most significant) and its inverse.
  int Frame(int bit, bool inverse) const;
};

struct FrameLayout {
  cv::Size projector_size;
  std::string files;  // e.g. "capture/{frame:02}-{view}.png"
  std::vector<std::string> views;
  int white = 0;
  int black = 0;
  CodeLayout columns;
  CodeLayout rows;
  int min_bits = 0;  // 0 = every bit

  // The file of frame `frame` of `view`, relative to the capture folder.
  // Checks `files`, `frame` and `view` as ParseFrameLayout does
  // (INVALID_ARGUMENT naming the key), so it is safe on any layout.
  absl::StatusOr<std::string> FileName(int frame, absl::string_view view) const;
};

// Parses a layout file's text. INVALID_ARGUMENT naming the key for a
// missing or bad field (e.g. "columns.bits: 12 bits cannot code ... "),
// also for a template that gives any frame the layout uses a bad file name.
absl::StatusOr<FrameLayout> ParseFrameLayout(absl::string_view json);
// The same for a file (at most 1 MiB, refused by its size before it is
// read), its path in front of the errors.
absl::StatusOr<FrameLayout> LoadFrameLayout(const std::filesystem::path& path);

// Loads one view's frames under `capture_dir` in the order Decode expects
// (one exposure). NOT_FOUND naming the file for a missing frame;
// INVALID_ARGUMENT for an unknown view.
absl::StatusOr<ViewFrames> LoadLayoutView(
    const FrameLayout& layout, const std::filesystem::path& capture_dir,
    const std::string& view);

}  // namespace hdrstereo::structured_light

#endif  // HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_FRAME_LAYOUT_H_
