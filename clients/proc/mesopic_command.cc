// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc mesopic --in IMG --display-cd 2 [--source-cd 200]
//                        [--method shin|wanat-saturation|rods|none] --out IMG
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "processing/mesopic/retarget.h"

namespace hdrstereo::proc {
namespace {

struct MesopicArgs {
  std::string in;
  std::string out;
  double display_cd = 2;
  double source_cd = 200;
  std::string method = "shin";
  bool no_tone_curve = false;
};

absl::Status RunMesopic(const MesopicArgs& args) {
  ASSIGN_OR_RETURN(mesopic::Method method,
                   mesopic::MethodFromName(args.method));
  ASSIGN_OR_RETURN(io::DecodedImage image, io::DecodeImageFile(args.in));
  cv::Mat input = image.pixels;
  // 8-bit display images go through as sRGB; anything else as linear float.
  if (input.depth() != CV_8U) input = io::ToFloat(input);
  if (input.channels() == 1) cv::merge(std::vector<cv::Mat>(3, input), input);
  mesopic::RetargetOptions options;
  options.display_cd = args.display_cd;
  options.source_cd = args.source_cd;
  options.method = method;
  options.tone_curve = !args.no_tone_curve;
  absl::StatusOr<cv::Mat> out = mesopic::Retarget(input, options);
  if (!out.ok()) {
    return absl::Status(out.status().code(),
                        absl::StrCat(args.in, ": ", out.status().message()));
  }
  cv::Mat encoded = *out;
  if (encoded.depth() != CV_8U) encoded.convertTo(encoded, CV_8U, 255.0);
  RETURN_IF_ERROR(io::WriteImage(args.out, encoded));
  std::cout << args.in << " retargeted (" << mesopic::MethodName(method) << ", "
            << args.source_cd << " -> " << args.display_cd << " cd/m^2) to "
            << args.out << "\n";
  return absl::OkStatus();
}

void AddMesopicCommands(CLI::App& app) {
  auto args = std::make_shared<MesopicArgs>();
  CLI::App* cmd = app.add_subcommand(
      "mesopic", "Retarget an image for a dim display (thesis ch. 6)");
  cmd->add_option("--in", args->in, "Input image (sRGB 8-bit or linear HDR)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", args->out, "Output image (8-bit sRGB)")->required();
  cmd->add_option("--display-cd", args->display_cd,
                  "Peak luminance of the dimmed display, cd/m^2")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--source-cd", args->source_cd,
                  "Peak luminance the image was made for, cd/m^2")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--method", args->method,
                  "shin, wanat-saturation, rods or none")
      ->capture_default_str();
  cmd->add_flag("--no-tone-curve", args->no_tone_curve,
                "Colour retargeting only, without the global tone curve");
  cmd->callback([args] { SetOutcome(RunMesopic(*args)); });
}

const CommandGroup kGroup("mesopic", &AddMesopicCommands);

}  // namespace
}  // namespace hdrstereo::proc
