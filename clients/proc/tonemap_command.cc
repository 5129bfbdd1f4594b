// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc tonemap --op NAME|all --in FILE.exr [--right FILE.exr]
//                        --out DIR
// One image, or a left/right pair with shared normalisation (thesis 5.1:
// the same mapping for both views keeps a pair consistent for matching).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::proc {
namespace {

namespace fs = std::filesystem;

struct TonemapArgs {
  std::string op = "all";
  std::string in;
  std::string right;
  std::string out;
};

absl::StatusOr<cv::Mat> LoadRadiance(const std::string& path) {
  ASSIGN_OR_RETURN(io::DecodedImage image, io::DecodeImageFile(path));
  cv::Mat radiance = io::ToFloat(image.pixels);
  if (radiance.channels() == 1) {
    cv::merge(std::vector<cv::Mat>(3, radiance), radiance);
  }
  return radiance;
}

absl::Status RunTonemap(const TonemapArgs& args) {
  std::vector<tonemap::Operator> ops;
  if (args.op == "all") {
    ops = tonemap::AllOperators();
  } else {
    ASSIGN_OR_RETURN(tonemap::Operator op, tonemap::OperatorFromName(args.op));
    ops.push_back(op);
  }
  ASSIGN_OR_RETURN(cv::Mat left, LoadRadiance(args.in));
  std::optional<cv::Mat> right;
  if (!args.right.empty()) {
    ASSIGN_OR_RETURN(cv::Mat loaded, LoadRadiance(args.right));
    right = loaded;
  }
  std::error_code ec;
  fs::create_directories(args.out, ec);
  if (ec) {
    return absl::FailedPreconditionError(
        absl::StrCat("cannot create ", args.out, ": ", ec.message()));
  }
  const tonemap::Params params;
  for (tonemap::Operator op : ops) {
    const std::string name = tonemap::OperatorName(op);
    if (right.has_value()) {
      absl::StatusOr<std::pair<cv::Mat, cv::Mat>> pair =
          tonemap::ToneMapPair(left, *right, op, params);
      if (!pair.ok()) return pair.status();
      for (const auto& [view, image] :
           {std::pair{"left", pair->first}, std::pair{"right", pair->second}}) {
        const fs::path path = fs::path(args.out) / (name + "_" + view + ".png");
        RETURN_IF_ERROR(io::WritePng(path, image));
        std::cout << path.string() << "\n";
      }
    } else {
      ASSIGN_OR_RETURN(cv::Mat image, tonemap::ToneMap(left, op, params));
      const fs::path path = fs::path(args.out) / (name + ".png");
      RETURN_IF_ERROR(io::WritePng(path, image));
      std::cout << path.string() << "\n";
    }
  }
  return absl::OkStatus();
}

void AddTonemapCommands(CLI::App& app) {
  auto args = std::make_shared<TonemapArgs>();
  CLI::App* cmd = app.add_subcommand(
      "tonemap", "Tone-map HDR radiance with the thesis' seven operators");
  cmd->add_option("--op", args->op,
                  "reinhard, durand, fattal, drago, guided, domain-transform, "
                  "wls or all")
      ->capture_default_str();
  cmd->add_option("--in", args->in, "HDR radiance (.exr, .hdr, .pfm)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--right", args->right,
                  "The right view: the pair shares one normalisation")
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", args->out, "Output folder (8-bit PNGs)")->required();
  cmd->callback([args] { SetOutcome(RunTonemap(*args)); });
}

const CommandGroup kGroup("tonemap", &AddTonemapCommands);

}  // namespace
}  // namespace hdrstereo::proc
