// SPDX-License-Identifier: GPL-3.0-or-later
//
// decode: the stereo frames as linear images, decoded/<view>/exp_<tag>.*
// with exposures.txt. rectify: the same stacks rectified with the session's
// calibration capture (identity without one), exposures/<view>/.
#include <filesystem>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/base/status_macros.h"
#include "processing/calib/stereo_calibration.h"
#include "processing/io/capture_layout.h"
#include "processing/io/image.h"
#include "processing/pipeline/steps.h"

namespace hdrstereo::pipeline {
namespace fs = std::filesystem;
namespace {

// "<name> <seconds>" lines, the stack folders' exposures.txt.
std::string ExposureLine(const std::string& name, double seconds) {
  return absl::StrCat(name, " ", absl::StrFormat("%.17g", seconds), "\n");
}

absl::Status Decode(StepContext& c) {
  for (int v = 0; v < 2; ++v) {
    const std::string folder = absl::StrCat("decoded/", io::ViewName(v), "/");
    std::string list;
    for (const FrameInput& f : c.frames().stereo[v]) {
      ASSIGN_OR_RETURN(io::DecodedImage image,
                       io::DecodeImageFile(c.dir() / f.path));
      const bool is_float = image.pixels.depth() == CV_32F;
      const std::string name = absl::StrCat(
          "exp_", io::ExposureTag(f.exposure_s), is_float ? ".pfm" : ".png");
      RETURN_IF_ERROR(
          c.outputs().WriteImage("decoded", folder + name, image.pixels));
      list += ExposureLine(name, f.exposure_s);
    }
    RETURN_IF_ERROR(
        c.outputs().WriteText("decoded", folder + "exposures.txt", list));
  }
  return absl::OkStatus();
}

// Whether rectification uses the rig's latest calibration: the session has
// no calibration capture of its own and the rig has one.
bool UsesRigCalibration(const StepContext& c) {
  return c.frames().calibration[0].empty() &&
         !c.input().rig_calibration.empty();
}

// The calibration capture's chessboard poses, when the session has one;
// else the rig's latest calibration, when there is one.
absl::StatusOr<std::optional<calib::StereoCalibration>> Calibrate(
    const StepContext& c) {
  if (UsesRigCalibration(c)) {
    return calib::LoadCalibration(c.input().rig_calibration);
  }
  if (c.frames().calibration[0].empty()) return std::nullopt;
  std::vector<cv::Mat> images[2];
  std::vector<std::string> names[2];
  for (int v = 0; v < 2; ++v) {
    for (const FrameInput& f : c.frames().calibration[v]) {
      ASSIGN_OR_RETURN(const cv::Mat image, c.Read(f.path));
      images[v].push_back(io::To8Bit(image));
      names[v].push_back(f.path);
    }
  }
  return calib::CalibrateStereoFromImages(images[0], images[1], names[0],
                                          names[1]);
}

absl::Status Rectify(StepContext& c) {
  hdr::ExposureStack stacks[2];
  for (int v = 0; v < 2; ++v) {
    ASSIGN_OR_RETURN(stacks[v],
                     hdr::LoadStack(c.dir() / "decoded" / io::ViewName(v)));
  }
  ASSIGN_OR_RETURN(const std::optional<calib::StereoCalibration> calibration,
                   Calibrate(c));
  std::optional<calib::RectificationMaps> maps;
  std::string note = "identity: no calibration capture in the session\n";
  if (calibration) {
    ASSIGN_OR_RETURN(maps, calib::ComputeRectificationMaps(*calibration));
    RETURN_IF_ERROR(
        c.outputs().Write("rectification", "exposures/rectification.yml",
                          [&](const fs::path& path) {
                            return calib::SaveCalibration(path, *calibration);
                          }));
    note = UsesRigCalibration(c)
               ? absl::StrFormat("calibrated: %s, rms %.3f px\n",
                                 c.input().rig_calibration_label,
                                 calibration->rms_stereo)
               : absl::StrFormat(
                     "calibrated: %d board pairs, rms %.3f px\n",
                     static_cast<int>(c.frames().calibration[0].size()),
                     calibration->rms_stereo);
  }
  for (int v = 0; v < 2; ++v) {
    const std::string folder = absl::StrCat("exposures/", io::ViewName(v), "/");
    std::string list;
    for (size_t i = 0; i < stacks[v].images.size(); ++i) {
      cv::Mat image = stacks[v].images[i];
      if (maps) {
        ASSIGN_OR_RETURN(image, calib::Rectify(image, *maps,
                                               v == 0 ? calib::View::kLeft
                                                      : calib::View::kRight));
      }
      const std::string name = fs::path(stacks[v].names[i]).filename().string();
      RETURN_IF_ERROR(c.outputs().WriteImage("exposure", folder + name, image));
      list += ExposureLine(name, stacks[v].exposure_s[i]);
    }
    RETURN_IF_ERROR(
        c.outputs().WriteText("exposure", folder + "exposures.txt", list));
  }
  return c.outputs().WriteText("rectification", "exposures/rectification.txt",
                               note);
}

}  // namespace

absl::StatusOr<ConfiguredStep> ConfigureDecode(const StepContext&) {
  return ConfiguredStep{nlohmann::json::object(), &Decode};
}

absl::StatusOr<ConfiguredStep> ConfigureRectify(const StepContext& c) {
  nlohmann::json params = nlohmann::json::object();
  // A new rig calibration rectifies again.
  if (UsesRigCalibration(c)) {
    params["rig_calibration"] = c.input().rig_calibration_label;
  }
  return ConfiguredStep{params, &Rectify};
}

}  // namespace hdrstereo::pipeline
