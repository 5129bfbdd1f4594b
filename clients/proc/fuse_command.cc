// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc fuse --candidates DIR --guide LEFT --max-disp D
//                     --out fused.pfm [--method alpha|mean|median]
//                     [--sigma S] [--lambda L] [--smoothness MODEL]
//                     [--fusion-move]
// Fuses every *.pfm disparity map in DIR (thesis 5.2.2: graph-cut
// alpha-expansion; mean and median as baselines). Non-finite, negative or
// > max-disp values are invalid. The guide (left view) is any image the
// project decodes: 8/16-bit, or float in [0, 1].
#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/fusion/fusion.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"

namespace hdrstereo::proc {
namespace {

namespace fs = std::filesystem;

struct FuseArgs {
  std::string candidates;
  std::string guide;
  int max_disp = 0;
  std::string out;
  std::string method = "alpha";
  double sigma = 1.0;
  double lambda = 1.0;
  std::string smoothness = "potts-linear";
  bool fusion_move = false;
};

absl::StatusOr<std::vector<cv::Mat>> LoadCandidates(const std::string& dir) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end;
       it.increment(ec)) {
    if (it->is_regular_file() && it->path().extension() == ".pfm") {
      files.push_back(it->path());
    }
  }
  if (ec) {
    return absl::NotFoundError(
        absl::StrCat("cannot list ", dir, ": ", ec.message()));
  }
  if (files.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("no .pfm disparity maps in ", dir));
  }
  std::sort(files.begin(), files.end());
  std::vector<cv::Mat> out;
  for (const fs::path& f : files) {
    ASSIGN_OR_RETURN(cv::Mat m, io::ReadPfm(f));
    if (m.channels() != 1) {
      return absl::InvalidArgumentError(
          absl::StrCat(f.string(), ": a disparity map must have 1 channel"));
    }
    out.push_back(m);
    std::cout << "candidate " << f.string() << "\n";
  }
  return out;
}

absl::StatusOr<cv::Mat> LoadGuide(const std::string& path) {
  ASSIGN_OR_RETURN(io::DecodedImage image, io::DecodeImageFile(path));
  cv::Mat g = image.pixels;
  if (g.depth() == CV_16U) {
    g.convertTo(g, CV_8U, 1.0 / 257.0);
  } else if (g.depth() == CV_32F) {
    cv::Mat c = cv::min(cv::max(g, 0.0), 1.0);
    c.convertTo(g, CV_8U, 255.0);
  }
  if (g.depth() != CV_8U || (g.channels() != 1 && g.channels() != 3)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": the guide must be grey or BGR"));
  }
  return g;
}

absl::StatusOr<fusion::SmoothnessModel> SmoothnessFromName(
    const std::string& name) {
  static const std::map<std::string, fusion::SmoothnessModel> kModels = {
      {"potts-linear", fusion::SmoothnessModel::kPottsLinear},
      {"potts", fusion::SmoothnessModel::kPotts},
      {"potts-static-cue", fusion::SmoothnessModel::kPottsStaticCue},
      {"quadratic", fusion::SmoothnessModel::kQuadratic}};
  auto it = kModels.find(name);
  if (it == kModels.end()) {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown smoothness '", name,
                     "' (potts-linear, potts, potts-static-cue, quadratic)"));
  }
  return it->second;
}

absl::Status RunFuse(const FuseArgs& args) {
  ASSIGN_OR_RETURN(std::vector<cv::Mat> cands, LoadCandidates(args.candidates));
  cv::Mat fused;
  if (args.method == "mean" || args.method == "median") {
    ASSIGN_OR_RETURN(cv::Mat r, args.method == "mean"
                                    ? fusion::FuseMean(cands, args.max_disp)
                                    : fusion::FuseMedian(cands, args.max_disp));
    fused = r;
  } else if (args.method == "alpha") {
    if (args.guide.empty()) {
      return absl::InvalidArgumentError("--method alpha needs --guide");
    }
    ASSIGN_OR_RETURN(cv::Mat guide, LoadGuide(args.guide));
    ASSIGN_OR_RETURN(fusion::SmoothnessModel model,
                     SmoothnessFromName(args.smoothness));
    fusion::FusionOptions params;
    params.max_disp = args.max_disp;
    params.sigma = args.sigma;
    params.lambda = args.lambda;
    params.smoothness = model;
    params.candidate_labels_only = args.fusion_move;
    ASSIGN_OR_RETURN(fusion::FusionResult r,
                     fusion::FuseAlphaExpansion(cands, guide, params));
    fused = r.disparity;
    const fusion::SolverStats& s = r.stats;
    std::cout << "energy " << s.energy_before << " -> " << s.energy_after
              << " in " << s.cycles << " cycles, " << s.expansions
              << " expansions (" << s.accepted << " accepted); setup "
              << s.setup_seconds << " s, graphs " << s.build_seconds
              << " s, max-flow " << s.maxflow_seconds << " s\n";
  } else {
    return absl::InvalidArgumentError(absl::StrCat(
        "unknown --method '", args.method, "' (alpha, mean, median)"));
  }
  RETURN_IF_ERROR(io::WritePfm(args.out, fused));
  std::cout << args.out << "\n";
  return absl::OkStatus();
}

void AddFuseCommands(CLI::App& app) {
  auto args = std::make_shared<FuseArgs>();
  CLI::App* cmd = app.add_subcommand(
      "fuse",
      "Fuse disparity maps by graph-cut alpha-expansion (thesis 5.2.2)");
  cmd->add_option("--candidates", args->candidates,
                  "Folder of candidate disparity maps (*.pfm)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--guide", args->guide, "Left view (smoothness weights)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--max-disp", args->max_disp, "Largest disparity label")
      ->required()
      ->check(CLI::Range(1, 4096));
  cmd->add_option("--out", args->out, "Fused disparity (.pfm)")->required();
  cmd->add_option("--method", args->method, "alpha, mean or median")
      ->capture_default_str();
  cmd->add_option("--sigma", args->sigma, "Data-term sigma (px)")
      ->capture_default_str();
  cmd->add_option("--lambda", args->lambda, "Smoothness weight")
      ->capture_default_str();
  cmd->add_option("--smoothness", args->smoothness,
                  "potts-linear, potts, potts-static-cue or quadratic")
      ->capture_default_str();
  cmd->add_flag("--fusion-move", args->fusion_move,
                "Only labels near a candidate (faster, not full expansion)");
  cmd->callback([args] { SetOutcome(RunFuse(*args)); });
}

const CommandGroup kGroup("fuse", &AddFuseCommands);

}  // namespace
}  // namespace hdrstereo::proc
