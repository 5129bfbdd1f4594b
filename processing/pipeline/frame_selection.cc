// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/pipeline/frame_selection.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/core.hpp>
#include <set>
#include <system_error>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/base/status_macros.h"
#include "processing/io/capture_layout.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/gray_code.h"

namespace hdrstereo::pipeline {
namespace fs = std::filesystem;
namespace {

bool Wants(const std::vector<std::string>& steps, const std::string& step) {
  return std::find(steps.begin(), steps.end(), step) != steps.end();
}

absl::Status Exists(const fs::path& dir, const std::string& rel,
                    const std::string& what) {
  std::error_code ec;
  if (fs::is_regular_file(dir / rel, ec)) return absl::OkStatus();
  return absl::FailedPreconditionError(
      absl::StrCat(what, " ", rel, " is missing"));
}

absl::Status CheckStereo(const FrameSelection& sel, const SessionInput& in) {
  if (sel.stereo_capture < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("session ", in.session_name,
                     " has no stereo frames (no bracketed_stereo capture with "
                     "captures/<id>/<view>/stereo/ frames)"));
  }
  for (int v = 0; v < 2; ++v) {
    if (sel.stereo[v].size() < 2) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "bracketed_stereo capture %d: the %s view has %d stereo frames; "
          "HDR needs at least 2 exposures per view",
          sel.stereo_capture, io::ViewName(v), sel.stereo[v].size()));
    }
    for (const FrameInput& f : sel.stereo[v]) {
      if (!(f.exposure_s > 0)) {
        return absl::FailedPreconditionError(
            absl::StrCat("frame ", f.path, " has no exposure time"));
      }
      RETURN_IF_ERROR(Exists(in.session_dir, f.path, "frame"));
    }
  }
  std::vector<double> e[2];
  for (int v = 0; v < 2; ++v) {
    for (const FrameInput& f : sel.stereo[v]) e[v].push_back(f.exposure_s);
  }
  if (e[0] != e[1]) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "bracketed_stereo capture %d: left and right views have different "
        "exposures",
        sel.stereo_capture));
  }
  if (sel.calibration[0].size() != sel.calibration[1].size()) {
    return absl::FailedPreconditionError(
        absl::StrFormat("calibration capture %d: %d left and %d right poses",
                        sel.calibration_capture, sel.calibration[0].size(),
                        sel.calibration[1].size()));
  }
  return absl::OkStatus();
}

// Every pattern of every exposure of both views (capture_layout.h naming).
absl::Status CheckStructuredLight(const FrameSelection& sel,
                                  const SessionInput& in) {
  const int64_t id = sel.structured_light_capture;
  for (int v = 0; v < 2; ++v) {
    if (sel.structured_light_view[v].empty()) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "structured_light capture %d has no %s view", id, io::ViewName(v)));
    }
  }
  std::map<std::string, std::set<std::string>> present[2];  // tag -> ids
  int bits[2] = {0, 0};  // column, row bit planes seen
  for (const FrameInput& f : sel.structured_light) {
    RETURN_IF_ERROR(Exists(in.session_dir, f.path, "structured-light frame"));
    const bool has_inv = absl::EndsWith(f.pattern, "_inv");
    const std::string frame_id =
        absl::StrCat(f.pattern, f.inverse && !has_inv ? "_inv" : "");
    present[f.view_index][io::ExposureTag(f.exposure_s)].insert(frame_id);
    int bit = 0;
    if (std::sscanf(f.pattern.c_str(), "col_b%d", &bit) == 1) {
      bits[0] = std::max(bits[0], bit + 1);
    } else if (std::sscanf(f.pattern.c_str(), "row_b%d", &bit) == 1) {
      bits[1] = std::max(bits[1], bit + 1);
    }
  }
  const cv::Size psize =
      in.projector_size
          ? cv::Size(in.projector_size->first, in.projector_size->second)
          : cv::Size(1 << bits[0], 1 << bits[1]);
  std::set<std::string> tags;
  for (const auto& p : present) {
    for (const auto& [tag, ids] : p) tags.insert(tag);
  }
  for (int v = 0; v < 2; ++v) {
    for (const std::string& tag : tags) {
      for (const structured_light::Pattern& p :
           structured_light::AllPatterns(psize)) {
        const std::string frame_id = structured_light::FrameId(p);
        if (present[v][tag].count(frame_id)) continue;
        io::FrameKey key;
        key.role = io::FrameRole::kStructuredLight;
        key.exposure_s = io::ParseExposureTag(tag).value_or(0);
        key.pattern = p.Id();
        key.inverse = p.inverse;
        return absl::FailedPreconditionError(absl::StrFormat(
            "structured_light capture %d: %s view, exposure %s: bit plane %s "
            "is missing (%s.*)",
            id, io::ViewName(v), tag, frame_id,
            io::FrameStem(id, sel.structured_light_view[v], key)));
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<FrameSelection> SelectFrames(const SessionInput& in) {
  if (in.frames.empty()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "session ", in.session_name, " has no frames: nothing to process"));
  }
  FrameSelection sel;
  for (const FrameInput& f : in.frames) {
    if (f.capture_kind == io::CaptureKind::kBracketedStereo &&
        f.role == io::FrameRole::kStereo) {
      sel.stereo_capture = std::max(sel.stereo_capture, f.capture_id);
    } else if (f.capture_kind == io::CaptureKind::kStructuredLight) {
      sel.structured_light_capture =
          std::max(sel.structured_light_capture, f.capture_id);
    } else if (f.capture_kind == io::CaptureKind::kCalibration) {
      sel.calibration_capture = std::max(sel.calibration_capture, f.capture_id);
    }
  }
  for (const FrameInput& f : in.frames) {
    if (f.view_index < 0 || f.view_index > 1) continue;
    const size_t v = static_cast<size_t>(f.view_index);
    if (f.capture_id == sel.stereo_capture &&
        f.capture_kind == io::CaptureKind::kBracketedStereo &&
        f.role == io::FrameRole::kStereo) {
      sel.stereo[v].push_back(f);
    } else if (f.capture_id == sel.structured_light_capture &&
               f.capture_kind == io::CaptureKind::kStructuredLight) {
      sel.structured_light.push_back(f);
      if (sel.structured_light_view[v].empty()) {
        absl::StatusOr<io::FramePath> path = io::ParseFramePath(f.path);
        if (!path.ok()) {
          return absl::FailedPreconditionError(path.status().message());
        }
        sel.structured_light_view[v] = path->view;
      }
    } else if (f.capture_id == sel.calibration_capture &&
               f.capture_kind == io::CaptureKind::kCalibration) {
      sel.calibration[v].push_back(f);
    }
  }
  for (auto& list : sel.stereo) {
    std::stable_sort(list.begin(), list.end(),
                     [](const FrameInput& a, const FrameInput& b) {
                       return a.exposure_s > b.exposure_s;
                     });
  }
  for (auto& list : sel.calibration) {
    std::sort(
        list.begin(), list.end(), [](const FrameInput& a, const FrameInput& b) {
          return fs::path(a.path).filename() < fs::path(b.path).filename();
        });
  }
  return sel;
}

absl::Status CheckSelection(const FrameSelection& frames,
                            const SessionInput& input,
                            const std::vector<std::string>& steps) {
  if (Wants(steps, "decode")) RETURN_IF_ERROR(CheckStereo(frames, input));
  if (Wants(steps, "sl_groundtruth") && frames.structured_light_capture >= 0) {
    RETURN_IF_ERROR(CheckStructuredLight(frames, input));
  }
  for (const std::string& rel :
       {input.sim_truth_disparity, input.sim_truth_nonoccluded}) {
    if (!rel.empty()) {
      RETURN_IF_ERROR(Exists(input.session_dir, rel, "simulator truth"));
    }
  }
  return absl::OkStatus();
}

}  // namespace hdrstereo::pipeline
