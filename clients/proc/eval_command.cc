// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc eval --disp D.pfm --gt GT.pfm [--mask M.png]
//     [--nonocc N.png] [--scale S] [--json] [--error-png E.png]
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/eval/disparity_eval.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"

namespace hdrstereo::proc {
namespace {

struct EvalArgs {
  std::string disp, gt, mask, nonocc, error_png;
  double scale = 1.0;
  double max_error = 4.0;
  bool json = false;
  bool gt_zero_valid = false;
};

// Disparity-like file as CV_32FC1 in its own units (no 1/255 scaling).
absl::StatusOr<cv::Mat> LoadDisparity(const std::string& path) {
  ASSIGN_OR_RETURN(io::DecodedImage image, io::DecodeImageFile(path));
  if (image.pixels.channels() != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": a disparity map must have one channel"));
  }
  cv::Mat f;
  image.pixels.convertTo(f, CV_32F);
  return f;
}

// Any image as CV_8UC1, 255 where non-zero.
absl::StatusOr<cv::Mat> LoadMask(const std::string& path) {
  ASSIGN_OR_RETURN(io::DecodedImage image, io::DecodeImageFile(path));
  cv::Mat m = image.pixels;
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
  if (m.channels() != 1) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": not a mask"));
  }
  return cv::Mat(m > 0);
}

absl::Status RunEval(const EvalArgs& args) {
  ASSIGN_OR_RETURN(cv::Mat disp, LoadDisparity(args.disp));
  ASSIGN_OR_RETURN(cv::Mat gt, LoadDisparity(args.gt));
  cv::Mat mask, nonocc;
  if (!args.mask.empty()) {
    ASSIGN_OR_RETURN(cv::Mat m, LoadMask(args.mask));
    mask = m;
  }
  if (!args.nonocc.empty()) {
    ASSIGN_OR_RETURN(cv::Mat m, LoadMask(args.nonocc));
    nonocc = m;
  }
  eval::EvalOptions options;
  options.disparity_scale = args.scale;
  options.gt_zero_valid = args.gt_zero_valid;
  ASSIGN_OR_RETURN(eval::DisparityEvaluation e,
                   eval::EvaluateDisparity(disp, gt, nonocc, mask, options));
  if (!args.error_png.empty()) {
    ASSIGN_OR_RETURN(cv::Mat err,
                     eval::ColorizeError(disp, gt, args.max_error, options));
    RETURN_IF_ERROR(io::WritePng(args.error_png, err));
  }
  std::cout << (args.json ? eval::EvaluationToJson(e) + "\n"
                          : eval::EvaluationToText(e));
  return absl::OkStatus();
}

void AddEvalCommands(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  auto* cmd = app.add_subcommand(
      "eval", "Score a disparity map against ground truth (RMSE, bad pixels)");
  cmd->add_option("--disp", args->disp, "Estimated disparity (.pfm)")
      ->required();
  cmd->add_option("--gt", args->gt, "Ground-truth disparity (.pfm)")
      ->required();
  cmd->add_option("--mask", args->mask, "Only pixels non-zero here");
  cmd->add_option("--nonocc", args->nonocc,
                  "Non-occlusion mask (non-zero = visible in both views)");
  cmd->add_option("--scale", args->scale,
                  "Multiply the estimate by this before scoring")
      ->capture_default_str();
  cmd->add_flag("--gt-zero-valid", args->gt_zero_valid,
                "Truth 0 is a disparity (default: unknown, as Middlebury)");
  cmd->add_option("--error-png", args->error_png, "Colour-mapped error image");
  cmd->add_option("--max-error", args->max_error,
                  "Error at the top of the error colour map (px)")
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "Print JSON instead of a table");
  cmd->callback([args] { SetOutcome(RunEval(*args)); });
}

const CommandGroup kGroup("eval", &AddEvalCommands);

}  // namespace
}  // namespace hdrstereo::proc
