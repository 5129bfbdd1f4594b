// SPDX-License-Identifier: GPL-3.0-or-later
//
// The one owner of the capture layout on disk, relative to a session
// folder:
//
//   captures/<id>/<view>/<role>/<file stem>.<ext>   one frame
//   captures/<id>/truth/                            the simulator's truth
//
//   <view>       "left" / "right" for a pair, "view0", "view1", ... else
//   <role>       ambient | stereo | structured_light | calibration
//   <file stem>  ambient, stereo:   exp_<tag>
//                structured_light:  sl_<pattern>[_inv]_exp_<tag>
//                                   (<pattern> col_bNN, row_bNN, white,
//                                   black)
//                calibration:       pose_NN
//   <tag>        ExposureTag: "1-125s" for 1/125 s, "0.5s", "2s"
//
// The camera decides <ext>. Capture jobs write it (daemon/jobs), the
// pipeline and hdrstereo-proc read it, the simulator's test sessions
// render it; all of them through these functions.
#ifndef HDRSTEREO_PROCESSING_IO_CAPTURE_LAYOUT_H_
#define HDRSTEREO_PROCESSING_IO_CAPTURE_LAYOUT_H_

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

// What a capture takes (the plan's kind, as stored in SQLite).
enum class CaptureKind { kBracketedStereo, kStructuredLight, kCalibration };
// "bracketed_stereo", "structured_light", "calibration".
const char* CaptureKindName(CaptureKind kind);
absl::StatusOr<CaptureKind> ParseCaptureKind(absl::string_view name);

// The folder below the view: what a frame is for.
enum class FrameRole { kAmbient, kStereo, kStructuredLight, kCalibration };
// "ambient", "stereo", "structured_light", "calibration".
const char* FrameRoleName(FrameRole role);
absl::StatusOr<FrameRole> ParseFrameRole(absl::string_view name);
// The capture kind whose frames have `role`.
CaptureKind KindOfRole(FrameRole role);

// "left"/"right" when there are two views, "view<i>" otherwise.
std::string ViewName(int view_index, int views = 2);
// The index of a view folder: left 0, right 1, view<i> i; nullopt else.
std::optional<int> ParseViewName(absl::string_view name);

// "1-125s" for 1/125 s, "0.5s", "2s": the file-name-safe exposure tag.
std::string ExposureTag(double seconds);
// Exposure time of a tag ("1-30s" -> 1/30, "0.5s" -> 0.5); nullopt when it
// is not one.
std::optional<double> ParseExposureTag(absl::string_view tag);

// What names a frame inside its role folder.
struct FrameKey {
  FrameRole role = FrameRole::kStereo;
  double exposure_s = 0;  // ambient, stereo, structured light
  std::string pattern;    // structured light: "col_b03", "white", ...
  bool inverse = false;   // structured light
  int pose = 0;           // calibration
};

// "exp_1-125s", "sl_col_b03_inv_exp_1-30s", "pose_03".
std::string FrameFileStem(const FrameKey& key);
// The key of a file stem in a `role` folder; nullopt for other names.
std::optional<FrameKey> ParseFrameFileStem(FrameRole role,
                                           absl::string_view stem);

// "captures": every capture of a session is below it.
inline constexpr char kCapturesDir[] = "captures";
// "captures/<id>".
std::string CaptureDir(int64_t capture_id);
// "captures/<id>/truth": the simulator's exact truth of a stereo capture.
std::string TruthDir(int64_t capture_id);
// "captures/<id>/<view>/<role>": a view's frames of one role.
std::string RoleDir(int64_t capture_id, absl::string_view view, FrameRole role);
// "captures/<id>/<view>/<role>/<file stem>", without the extension.
std::string FrameStem(int64_t capture_id, absl::string_view view,
                      const FrameKey& key);

// A frame's path relative to the session folder, taken apart.
struct FramePath {
  int64_t capture_id = 0;
  std::string view;    // the folder: "left", "view3", ...
  int view_index = 0;  // ParseViewName(view)
  FrameKey key;
};
// INVALID_ARGUMENT naming the part that does not fit the layout (a file
// outside captures/<id>/<view>/<role>/, an unknown role, a file name its
// role does not use).
absl::StatusOr<FramePath> ParseFramePath(absl::string_view relative_path);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_CAPTURE_LAYOUT_H_
