// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc table --scene NAME [--scene NAME ...] [--width W]
//                      [--baseline-mm B] [--markdown OUT.md]
//                      [--thesis-fusion | --no-plane-prior --no-photo-check
//                       --no-speckle-filter]
//                      [--one-fused4] [--details]
// hdrstereo-proc table --left-stack L/ --right-stack R/ --truth disp.pfm
//                      [--nonoccluded mask.png] [--max-disp D]
// The thesis' Tables 5.2 / 5.3 (RMSE and bad-1px of ldr, the seven TMOs,
// hdr, mean, median, fused-4, fused; see
// processing/experiment/thesis_table.h) for simulated scenes rendered with the
// thesis' eight exposures (1/15 .. 1/2000 s, exact truth), or for a
// recorded data set: two exposure stack folders (exposures.txt, as for
// `merge`) and a left-view truth disparity.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "clients/proc/command_registry.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hardware/sim/truth.h"
#include "processing/base/status_macros.h"
#include "processing/experiment/thesis_table.h"
#include "processing/hdr/stack.h"
#include "processing/io/hdr_formats.h"

namespace hdrstereo::proc {
namespace {

struct TableArgs {
  std::vector<std::string> scenes;
  int width = 320;
  double baseline_mm = 150;
  std::string left_stack, right_stack, truth, nonoccluded;
  int max_disp = 0;
  std::string markdown;
  double sigma = 1.0;
  double lambda = 1.0;
  double inconsistent_confidence = 1.0;
  double edge_weight = 1.0;
  bool thesis_fusion = false;
  bool no_plane_prior = false;
  bool no_photo_check = false;
  bool no_speckle_filter = false;
  bool one_fused4 = false;
  bool details = false;
};

// The thesis' eight exposures (Fig. 3.2), ISO 100.
const std::vector<double>& ThesisExposures() {
  static const std::vector<double> kTimes = {1.0 / 15,   1.0 / 30,  1.0 / 60,
                                             1.0 / 125,  1.0 / 250, 1.0 / 500,
                                             1.0 / 1000, 1.0 / 2000};
  return kTimes;
}

absl::StatusOr<experiment::TableInput> SimInput(const std::string& name,
                                                int width, double baseline_mm) {
  ASSIGN_OR_RETURN(sim::Scene scene, sim::LoadScene(name));
  sim::ScaleCamera(scene, width);
  sim::SimWorld world(scene);
  experiment::TableInput in;
  in.name = name;
  for (double t : ThesisExposures()) {
    world.SetStagePosition(0);
    in.left.images.push_back(world.RenderExposure({t, 100}, 8));
    world.SetStagePosition(baseline_mm);
    in.right.images.push_back(world.RenderExposure({t, 100}, 8));
  }
  in.left.exposure_s = in.right.exposure_s = ThesisExposures();
  in.left.camera = in.right.camera = "sim";
  ASSIGN_OR_RETURN(sim::StereoTruth truth, world.Truth(0, baseline_mm));
  in.truth = truth.left.disparity;
  in.nonoccluded = truth.left.nonoccluded;
  in.ldr_index = 4;  // 1/250 s, the thesis' middle exposure (Fig. 3.4)
  return in;
}

absl::StatusOr<experiment::TableInput> StackInput(const TableArgs& args) {
  experiment::TableInput in;
  in.name = std::filesystem::path(args.left_stack).parent_path().filename();
  if (in.name.empty()) in.name = "data";
  ASSIGN_OR_RETURN(hdr::ExposureStack l, hdr::LoadStack(args.left_stack));
  ASSIGN_OR_RETURN(hdr::ExposureStack r, hdr::LoadStack(args.right_stack));
  in.left = l;
  in.right = r;
  ASSIGN_OR_RETURN(cv::Mat truth, io::ReadPfm(args.truth));
  in.truth = truth;
  if (!args.nonoccluded.empty()) {
    in.nonoccluded = cv::imread(args.nonoccluded, cv::IMREAD_GRAYSCALE);
    if (in.nonoccluded.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("cannot read ", args.nonoccluded));
    }
  }
  in.max_disp = args.max_disp;
  return in;
}

absl::Status RunTable(const TableArgs& args) {
  std::vector<experiment::TableInput> inputs;
  const bool stacks = !args.left_stack.empty() || !args.right_stack.empty();
  if (stacks == !args.scenes.empty()) {
    return absl::InvalidArgumentError(
        "give either --scene or --left-stack/--right-stack/--truth");
  }
  if (stacks) {
    if (args.left_stack.empty() || args.right_stack.empty() ||
        args.truth.empty()) {
      return absl::InvalidArgumentError(
          "--left-stack, --right-stack and --truth go together");
    }
    ASSIGN_OR_RETURN(experiment::TableInput in, StackInput(args));
    inputs.push_back(in);
  }
  for (const std::string& name : args.scenes) {
    ASSIGN_OR_RETURN(experiment::TableInput in,
                     SimInput(name, args.width, args.baseline_mm));
    inputs.push_back(in);
  }
  std::vector<experiment::TableResult> results;
  for (const experiment::TableInput& in : inputs) {
    std::cerr << "matching and fusing " << in.name << " (" << in.truth.cols
              << "x" << in.truth.rows << ")\n";
    experiment::TableOptions topt;
    topt.experiment.fusion.sigma = args.sigma;
    topt.experiment.fusion.lambda = args.lambda;
    topt.experiment.fusion.edge_weight = args.edge_weight;
    topt.experiment.inconsistent_confidence = args.inconsistent_confidence;
    topt.experiment.robust_fusion.enabled = !args.thesis_fusion;
    topt.experiment.robust_fusion.planes.enabled = !args.no_plane_prior;
    topt.experiment.robust_fusion.photo.enabled = !args.no_photo_check;
    topt.experiment.robust_fusion.speckles.enabled = !args.no_speckle_filter;
    topt.fused4_all_subsets = !args.one_fused4;
    topt.details = args.details;
    ASSIGN_OR_RETURN(experiment::TableResult r,
                     experiment::RunThesisTable(in, topt));
    results.push_back(r);
  }
  const std::string table =
      experiment::FormatTable(results) + experiment::FormatDetails(results);
  std::cout << table;
  if (!args.markdown.empty()) {
    std::ofstream f(args.markdown);
    f << table;
    if (!f) {
      return absl::FailedPreconditionError(
          absl::StrCat("cannot write ", args.markdown));
    }
  }
  return absl::OkStatus();
}

void AddTableCommands(CLI::App& app) {
  auto args = std::make_shared<TableArgs>();
  CLI::App* cmd = app.add_subcommand(
      "table",
      "Thesis Tables 5.2/5.3: ldr, 7 TMOs, hdr (HDR-CVF), mean, median, "
      "fused-4, fused");
  cmd->add_option("--scene", args->scenes,
                  "Simulated scene (bundled name or JSON), repeatable");
  cmd->add_option("--width", args->width, "Rendered width (px)")
      ->check(CLI::Range(64, 4000))
      ->capture_default_str();
  cmd->add_option("--baseline-mm", args->baseline_mm, "Stereo baseline")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--left-stack", args->left_stack, "Left exposure stack")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--right-stack", args->right_stack, "Right exposure stack")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--truth", args->truth, "Left truth disparity (.pfm)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--nonoccluded", args->nonoccluded,
                  "8-bit mask, non-zero = scored")
      ->check(CLI::ExistingFile);
  cmd->add_option("--max-disp", args->max_disp,
                  "Largest disparity (0 = from the truth)");
  cmd->add_option("--markdown", args->markdown, "Also write the table here");
  CLI::Option* thesis = cmd->add_flag(
      "--thesis-fusion", args->thesis_fusion,
      "The thesis' fusion (one graph cut, every candidate weighed "
      "alike) instead of weighing each by its evidence");
  cmd->add_flag("--no-plane-prior", args->no_plane_prior,
                "Fusion without planes on surfaces without texture")
      ->excludes(thesis);
  cmd->add_flag("--no-photo-check", args->no_photo_check,
                "Fusion without the step that takes the candidate the views "
                "agree with best on textured surfaces")
      ->excludes(thesis);
  cmd->add_flag("--no-speckle-filter", args->no_speckle_filter,
                "Fusion without removing small islands of another surface's "
                "disparity")
      ->excludes(thesis);
  cmd->add_flag("--details", args->details,
                "Also per data set: bad-2px, bad-1px scaled with the width, "
                "the per-region split and the oracle of the seven");
  cmd->add_flag("--one-fused4", args->one_fused4,
                "fused-4 of the first four TMOs only, not the mean of all 35 "
                "subsets (for large sizes)");
  cmd->add_option("--sigma", args->sigma, "Thesis fusion: data-term sigma (px)")
      ->check(CLI::PositiveNumber)
      ->needs(thesis)
      ->capture_default_str();
  cmd->add_option("--lambda", args->lambda, "Fusion smoothness weight")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--inconsistent-confidence", args->inconsistent_confidence,
                  "Thesis fusion: data weight of a candidate's "
                  "LR-inconsistent pixels")
      ->check(CLI::Range(0.0, 1.0))
      ->needs(thesis)
      ->capture_default_str();
  cmd->add_option("--edge-weight", args->edge_weight,
                  "Fusion smoothness factor on guide edge pixels (Appendix "
                  "A useEdge: ~0; 1 = off)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  cmd->callback([args] { SetOutcome(RunTable(*args)); });
}

const CommandGroup kGroup("table", &AddTableCommands);

}  // namespace
}  // namespace hdrstereo::proc
