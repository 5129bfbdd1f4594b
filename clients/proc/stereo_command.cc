// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc stereo --left L --right R --min-disp 0 --max-disp D
//     [--hdr | --hdr-radiance-gradient] [--subpixel] [--threads N]
//     --out disp.pfm [--png colour.png]
#include <CLI/CLI.hpp>
#include <chrono>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/eval/disparity_eval.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "processing/stereo/cost_volume_stereo.h"

namespace hdrstereo::proc {
namespace {

struct StereoArgs {
  std::string left, right, out, png;
  int min_disp = 0;
  int max_disp = 64;
  bool hdr = false;
  bool hdr_radiance_gradient = false;
  bool subpixel = false;
  int threads = 0;
};

absl::StatusOr<cv::Mat> Load(const std::string& path) {
  ASSIGN_OR_RETURN(io::DecodedImage image, io::DecodeImageFile(path));
  return image.pixels;
}

absl::Status RunStereo(const StereoArgs& args) {
  ASSIGN_OR_RETURN(cv::Mat left, Load(args.left));
  ASSIGN_OR_RETURN(cv::Mat right, Load(args.right));
  const bool hdr = args.hdr || args.hdr_radiance_gradient;
  stereo::StereoOptions options =
      hdr ? stereo::StereoOptions::Hdr() : stereo::StereoOptions();
  if (args.hdr_radiance_gradient) {
    options.mode = stereo::CostMode::kHdrRadianceGradient;
  }
  options.min_disparity = args.min_disp;
  options.max_disparity = args.max_disp;
  options.subpixel = args.subpixel;
  options.threads = args.threads;
  cv::Mat l = left, r = right;
  if (hdr) {
    // Radiance files are float already; integer files are taken as linear.
    l = io::ToFloat(l);
    r = io::ToFloat(r);
  }
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(stereo::StereoResult result,
                   stereo::ComputeDisparity(l, r, options));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  RETURN_IF_ERROR(io::WritePfm(args.out, result.disparity));
  if (!args.png.empty()) {
    ASSIGN_OR_RETURN(cv::Mat colour,
                     eval::ColorizeDisparity(result.disparity, args.min_disp,
                                             args.max_disp));
    RETURN_IF_ERROR(io::WritePng(args.png, colour));
  }
  const double consistent = 100.0 * cv::countNonZero(result.consistent) /
                            static_cast<double>(result.consistent.total());
  std::cout << "disparity " << l.cols << "x" << l.rows << " in ["
            << args.min_disp << ", " << args.max_disp << "] ("
            << (hdr ? "HDR" : "LDR") << ") written to " << args.out << "; "
            << consistent << "% left-right consistent; " << seconds << " s\n";
  return absl::OkStatus();
}

void AddStereoCommands(CLI::App& app) {
  auto args = std::make_shared<StereoArgs>();
  auto* cmd = app.add_subcommand(
      "stereo", "Disparity by fast cost-volume filtering (thesis Eq. 4.1/4.2)");
  cmd->add_option("--left", args->left, "Left image (LDR or HDR radiance)")
      ->required();
  cmd->add_option("--right", args->right, "Right image")->required();
  cmd->add_option("--min-disp", args->min_disp, "Smallest disparity")
      ->capture_default_str();
  cmd->add_option("--max-disp", args->max_disp, "Largest disparity")
      ->required();
  cmd->add_flag("--hdr", args->hdr,
                "HDR matching on radiance (Eq. 4.2: log-luminance gradient)");
  cmd->add_flag("--hdr-radiance-gradient", args->hdr_radiance_gradient,
                "HDR matching with radiance gradients (Eq. 5.11)");
  cmd->add_flag("--subpixel", args->subpixel, "Parabola sub-pixel refinement");
  cmd->add_option("--threads", args->threads, "Threads (0 = all)")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "Disparity map (.pfm)")->required();
  cmd->add_option("--png", args->png, "Colour-mapped disparity (.png)");
  cmd->callback([args] { SetOutcome(RunStereo(*args)); });
}

const CommandGroup kGroup("stereo", &AddStereoCommands);

}  // namespace
}  // namespace hdrstereo::proc
