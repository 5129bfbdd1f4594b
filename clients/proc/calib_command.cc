// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc calibrate --captures DIR [--board 9x6] [--square 0.025]
// hdrstereo-proc rectify --rig FILE --view left|right --out-dir DIR INPUT...
#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/calib/stereo_calibration.h"
#include "processing/io/atomic_file.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"

namespace hdrstereo::proc {
namespace {

namespace fs = std::filesystem;

struct CalibrateArgs {
  std::string captures;
  std::string board = "9x6";
  double square = 0.025;
  std::string out;
  bool zero_distortion = false;
};

struct RectifyArgs {
  std::string rig;
  std::string view;
  std::string out_dir;
  std::vector<std::string> inputs;
};

bool IsImage(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return io::IsRawExtension(p) || ext == ".png" || ext == ".jpg" ||
         ext == ".jpeg" || ext == ".tif" || ext == ".tiff" || ext == ".pfm";
}

std::vector<fs::path> ImagesIn(const fs::path& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.is_regular_file() && IsImage(e.path())) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Left/right pairs: DIR/left/* with DIR/right/* (by sorted order), or
// DIR/left<suffix> with DIR/right<suffix> (e.g. left_03.png, right_03.png).
absl::StatusOr<std::pair<std::vector<fs::path>, std::vector<fs::path>>>
FindPairs(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return absl::NotFoundError(
        absl::StrCat("captures folder not found: ", dir.string()));
  }
  std::vector<fs::path> left, right;
  if (fs::is_directory(dir / "left", ec) &&
      fs::is_directory(dir / "right", ec)) {
    left = ImagesIn(dir / "left");
    right = ImagesIn(dir / "right");
    if (left.size() != right.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat(dir.string(), ": ", left.size(), " images in left/ but ",
                       right.size(), " in right/"));
    }
  } else {
    std::map<std::string, fs::path> l, r;
    for (const fs::path& p : ImagesIn(dir)) {
      const std::string name = p.filename().string();
      if (absl::StartsWith(name, "left")) l[name.substr(4)] = p;
      if (absl::StartsWith(name, "right")) r[name.substr(5)] = p;
    }
    for (const auto& [suffix, path] : l) {
      auto it = r.find(suffix);
      if (it == r.end()) {
        return absl::InvalidArgumentError(
            absl::StrCat("no right view for ", path.string()));
      }
      left.push_back(path);
      right.push_back(it->second);
    }
    if (l.size() != r.size()) {
      return absl::InvalidArgumentError(absl::StrCat(dir.string(), ": ",
                                                     l.size(), " left but ",
                                                     r.size(), " right views"));
    }
  }
  if (left.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "no calibration pairs in ", dir.string(),
        " (expected left/ and right/ folders or left*/right* files)"));
  }
  return std::make_pair(left, right);
}

absl::StatusOr<cv::Size> ParseBoard(const std::string& text) {
  std::vector<std::string> parts = absl::StrSplit(text, 'x');
  int w = 0, h = 0;
  if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &w) ||
      !absl::SimpleAtoi(parts[1], &h) || w < 2 || h < 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--board must be <inner corners per row>x<per column>, e.g. 9x6; got '",
        text, "'"));
  }
  return cv::Size(w, h);
}

absl::Status RunCalibrate(const CalibrateArgs& args) {
  ASSIGN_OR_RETURN(cv::Size board, ParseBoard(args.board));
  auto pairs = FindPairs(args.captures);
  if (!pairs.ok()) return pairs.status();
  std::vector<cv::Mat> left, right;
  std::vector<std::string> left_names, right_names;
  for (size_t i = 0; i < pairs->first.size(); ++i) {
    for (int side = 0; side < 2; ++side) {
      const fs::path& p = side == 0 ? pairs->first[i] : pairs->second[i];
      ASSIGN_OR_RETURN(io::DecodedImage img, io::DecodeImageFile(p));
      (side == 0 ? left : right).push_back(img.pixels);
      (side == 0 ? left_names : right_names).push_back(p.string());
    }
  }
  calib::CalibrationOptions options;
  options.board.inner_corners = board;
  options.board.square_m = args.square;
  options.zero_distortion = args.zero_distortion;
  ASSIGN_OR_RETURN(calib::StereoCalibration c,
                   calib::CalibrateStereoFromImages(left, right, left_names,
                                                    right_names, options));
  const fs::path out = args.out.empty() ? fs::path(args.captures) / "rig.yml"
                                        : fs::path(args.out);
  RETURN_IF_ERROR(calib::SaveCalibration(out, c));
  std::cout << "calibrated " << left.size() << " pairs: reprojection RMS "
            << c.rms_intrinsics << " px (intrinsics), " << c.rms_stereo
            << " px (stereo); baseline " << cv::norm(c.translation)
            << " m; written to " << out.string() << "\n";
  return absl::OkStatus();
}

absl::Status RunRectify(const RectifyArgs& args) {
  calib::View view;
  if (args.view == "left") {
    view = calib::View::kLeft;
  } else if (args.view == "right") {
    view = calib::View::kRight;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("--view must be left or right, got '", args.view, "'"));
  }
  ASSIGN_OR_RETURN(calib::StereoCalibration c,
                   calib::LoadCalibration(args.rig));
  ASSIGN_OR_RETURN(calib::RectificationMaps maps,
                   calib::ComputeRectificationMaps(c));
  std::error_code ec;
  fs::create_directories(args.out_dir, ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat("cannot create ", args.out_dir, ": ", ec.message()));
  }
  int written = 0;
  for (const std::string& input : args.inputs) {
    std::vector<fs::path> files;
    if (fs::is_directory(input, ec)) {
      files = ImagesIn(input);
      const fs::path list = fs::path(input) / "exposures.txt";
      if (fs::exists(list, ec)) {  // keep the stack usable after rectifying
        ASSIGN_OR_RETURN(std::string text, io::ReadFileBytes(list));
        RETURN_IF_ERROR(io::WriteFileAtomically(
            fs::path(args.out_dir) / "exposures.txt", text));
      }
    } else {
      files.push_back(input);
    }
    for (const fs::path& file : files) {
      ASSIGN_OR_RETURN(io::DecodedImage img, io::DecodeImageFile(file));
      absl::StatusOr<cv::Mat> rect = calib::Rectify(img.pixels, maps, view);
      if (!rect.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat(file.string(), ": ", rect.status().message()));
      }
      fs::path out = fs::path(args.out_dir) / file.filename();
      // RAW and JPEG inputs are written losslessly as 16-bit/8-bit TIFF.
      if (io::IsRawExtension(file) || file.extension() == ".jpg" ||
          file.extension() == ".jpeg") {
        out.replace_extension(".tiff");
      }
      RETURN_IF_ERROR(io::WriteImage(out, *rect));
      ++written;
    }
  }
  std::cout << "rectified " << written << " " << args.view << " images into "
            << args.out_dir << "\n";
  return absl::OkStatus();
}

void AddCalibCommands(CLI::App& app) {
  auto c = std::make_shared<CalibrateArgs>();
  CLI::App* calibrate = app.add_subcommand(
      "calibrate", "stereo-calibrate the rig from chessboard captures");
  calibrate
      ->add_option("--captures", c->captures,
                   "folder with left/ and right/ (or left*/right* files)")
      ->required();
  calibrate->add_option("--board", c->board, "inner corners, e.g. 9x6");
  calibrate->add_option("--square", c->square, "square size in metres")
      ->check(CLI::PositiveNumber);
  calibrate->add_option("--out", c->out,
                        "calibration file (default: <captures>/rig.yml)");
  calibrate->add_flag("--zero-distortion", c->zero_distortion,
                      "assume a distortion-free lens");
  calibrate->callback([c] { SetOutcome(RunCalibrate(*c)); });

  auto r = std::make_shared<RectifyArgs>();
  CLI::App* rectify = app.add_subcommand(
      "rectify", "rectify images (files or stack folders) of one view");
  rectify->add_option("--rig", r->rig, "calibration file from 'calibrate'")
      ->required();
  rectify->add_option("--view", r->view, "left or right")->required();
  rectify->add_option("--out-dir", r->out_dir, "output folder")->required();
  rectify->add_option("inputs", r->inputs, "image files or stack folders")
      ->required();
  rectify->callback([r] { SetOutcome(RunRectify(*r)); });
}

const CommandGroup kCalibGroup("calib", &AddCalibCommands);

}  // namespace
}  // namespace hdrstereo::proc
