// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc sl decode --capture DIR --out DIR [--projector WxH]
// hdrstereo-proc sl disparity --capture DIR --out DIR [--projector WxH]
//     [--min-disparity N] [--max-disparity N] [--max-hole-area N]
//     [--no-illumination] [--fit-radius N]
// either with --layout FILE [--min-bits N]
//
// DIR holds left/structured_light/ and right/structured_light/ frames as
// capture jobs write them (sl_col_b03_inv_exp_1-30s.png, ...), or, with
// --layout, a capture laid out by others as the layout file describes
// (processing/structured_light/frame_layout.h; its first two views are the
// left and right view).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/io/hdr_formats.h"
#include "processing/structured_light/capture_io.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/frame_layout.h"
#include "processing/structured_light/ground_truth.h"

namespace hdrstereo::proc {
namespace {

namespace sl = structured_light;

struct SlArgs {
  std::string capture;
  std::string out;
  std::string projector;  // WxH, empty = from the number of bit planes
  std::string layout;     // a frame layout file, empty = capture-job layout
  int min_bits = -1;      // -1 = the layout's (or every bit)
  int fit_radius = 2;
  std::string view = "both";
  int min_disparity = 0;
  int max_disparity = 0;
  int max_hole_area = 25;
  bool no_illumination = false;
};

absl::StatusOr<std::optional<cv::Size>> ParseProjector(const std::string& s) {
  if (s.empty()) return std::optional<cv::Size>();
  int w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(s.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 ||
      (x != 'x' && x != 'X') || w <= 0 || h <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--projector: expected WxH (e.g. 1024x768), got ", s));
  }
  return std::optional<cv::Size>(cv::Size(w, h));
}

// The view names of the capture: the layout's, or left and right.
absl::StatusOr<std::vector<std::string>> ViewNames(const SlArgs& args) {
  if (args.layout.empty()) return std::vector<std::string>{"left", "right"};
  ASSIGN_OR_RETURN(sl::FrameLayout layout, sl::LoadFrameLayout(args.layout));
  return layout.views;
}

absl::StatusOr<sl::DecodedView> LoadAndDecode(const SlArgs& args,
                                              const std::string& view) {
  absl::StatusOr<sl::ViewFrames> frames;
  sl::DecodeOptions options;
  if (!args.layout.empty()) {
    if (!args.projector.empty()) {
      return absl::InvalidArgumentError(
          "--projector and --layout: the layout file gives the projector");
    }
    ASSIGN_OR_RETURN(sl::FrameLayout layout, sl::LoadFrameLayout(args.layout));
    options.min_bits = layout.min_bits;
    frames = sl::LoadLayoutView(layout, args.capture, view);
  } else {
    ASSIGN_OR_RETURN(std::optional<cv::Size> projector,
                     ParseProjector(args.projector));
    frames = sl::LoadCaptureView(args.capture, view, projector);
  }
  if (!frames.ok()) return frames.status();
  if (args.min_bits >= 0) options.min_bits = args.min_bits;
  absl::StatusOr<sl::DecodedView> decoded = sl::Decode(*frames, options);
  if (!decoded.ok()) {
    return absl::Status(decoded.status().code(),
                        absl::StrCat(view, ": ", decoded.status().message()));
  }
  std::cout << absl::StrFormat(
      "%s: %dx%d, %d exposure(s), projector %dx%d: %d lit, %d decoded\n", view,
      decoded->column.cols, decoded->column.rows, frames->exposures.size(),
      frames->projector_size.width, frames->projector_size.height,
      decoded->lit_pixels, decoded->valid_pixels);
  for (const std::string& w : decoded->warnings) {
    std::cerr << "warning: " << view << ": " << w << "\n";
  }
  return decoded;
}

absl::Status RunDecode(const SlArgs& args) {
  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat("cannot create ", args.out, ": ", ec.message()));
  }
  ASSIGN_OR_RETURN(std::vector<std::string> names, ViewNames(args));
  std::vector<std::string> views = names;
  if (args.view != "both") views = {args.view};
  for (const std::string& view : views) {
    ASSIGN_OR_RETURN(sl::DecodedView d, LoadAndDecode(args, view));
    // 16-bit PNGs: projector column / row, 65535 = invalid.
    cv::Mat col, row;
    d.column.convertTo(col, CV_16U);
    d.row.convertTo(row, CV_16U);
    col.setTo(65535, d.column < 0);
    row.setTo(65535, d.row < 0);
    const std::filesystem::path out(args.out);
    for (const auto& [name, image] :
         {std::pair<std::string, cv::Mat>{"column", col},
          {"row", row},
          {"lit", d.lit}}) {
      RETURN_IF_ERROR(
          io::WritePng(out / absl::StrCat(view, "_", name, ".png"), image));
    }
    RETURN_IF_ERROR(io::WritePfm(out / absl::StrCat(view, "_confidence.pfm"),
                                 d.confidence));
  }
  std::cout << "wrote <view>_column.png, <view>_row.png (16-bit, 65535 = "
               "invalid), <view>_lit.png, <view>_confidence.pfm to "
            << args.out << "\n";
  return absl::OkStatus();
}

absl::Status RunDisparity(const SlArgs& args) {
  ASSIGN_OR_RETURN(std::vector<std::string> views, ViewNames(args));
  if (views.size() < 2) {
    return absl::InvalidArgumentError(
        "sl disparity needs two views; the layout names one");
  }
  ASSIGN_OR_RETURN(sl::DecodedView left, LoadAndDecode(args, (views)[0]));
  ASSIGN_OR_RETURN(sl::DecodedView right, LoadAndDecode(args, (views)[1]));
  sl::GroundTruthOptions options;
  options.match.fit_radius = args.fit_radius;
  options.match.min_disparity = args.min_disparity;
  options.match.max_disparity = args.max_disparity;
  options.max_hole_area = args.max_hole_area;
  options.use_illumination = !args.no_illumination;
  ASSIGN_OR_RETURN(sl::GroundTruth gt,
                   sl::ComputeGroundTruth(left, right, options));
  for (const std::string& w : gt.warnings) {
    std::cerr << "warning: " << w << "\n";
  }
  RETURN_IF_ERROR(sl::WriteMiddlebury(gt, args.out));
  std::cout << sl::StatsJson(gt.stats);
  std::cout << "wrote disp0GT.pfm, disp1GT.pfm, mask0nocc.png, sl_stats.json "
               "to "
            << args.out << "\n";
  return absl::OkStatus();
}

void AddCommon(CLI::App* cmd, SlArgs* args) {
  cmd->add_option("--capture", args->capture,
                  "Capture folder with left/ and right/structured_light/ "
                  "(or laid out as --layout says)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--out", args->out, "Output folder")->required();
  cmd->add_option("--projector", args->projector,
                  "Projector resolution WxH (default: 2^bits from the frames)");
  cmd->add_option("--layout", args->layout,
                  "JSON file saying which file is which pattern, for "
                  "captures laid out by others")
      ->check(CLI::ExistingFile);
  cmd->add_option("--min-bits", args->min_bits,
                  "Keep pixels that read at least N leading bits of each "
                  "code (0 = every bit; default: the layout's, else 0)")
      ->check(CLI::Range(0, 16));
}

void AddSlCommands(CLI::App& app) {
  CLI::App* sl = app.add_subcommand(
      "sl", "Structured-light ground truth from Gray codes (thesis 4.2)");
  sl->require_subcommand(1);

  auto decode_args = std::make_shared<SlArgs>();
  CLI::App* decode = sl->add_subcommand(
      "decode", "Decode projector column/row per pixel of each view");
  AddCommon(decode, decode_args.get());
  decode
      ->add_option("--view", decode_args->view,
                   "left, right (or a layout's view name) or both")
      ->capture_default_str();
  decode->callback([decode_args] { SetOutcome(RunDecode(*decode_args)); });

  auto disp_args = std::make_shared<SlArgs>();
  CLI::App* disparity = sl->add_subcommand(
      "disparity",
      "Ground-truth disparities (disp0GT.pfm, disp1GT.pfm, mask0nocc.png)");
  AddCommon(disparity, disp_args.get());
  disparity
      ->add_option("--min-disparity", disp_args->min_disparity,
                   "Smallest disparity searched, px")
      ->capture_default_str();
  disparity
      ->add_option("--max-disparity", disp_args->max_disparity,
                   "Largest disparity searched, px (0 = image width)")
      ->capture_default_str();
  disparity
      ->add_option("--max-hole-area", disp_args->max_hole_area,
                   "Largest hole of lit pixels filled, px")
      ->capture_default_str();
  disparity->add_flag("--no-illumination", disp_args->no_illumination,
                      "View disparities only (no projector matrix)");
  disparity
      ->add_option("--fit-radius", disp_args->fit_radius,
                   "Half-window of the line fitted through the codes along "
                   "a scanline, px")
      ->check(CLI::Range(0, 32))
      ->capture_default_str();
  disparity->callback([disp_args] { SetOutcome(RunDisparity(*disp_args)); });
}

const CommandGroup kGroup("sl", &AddSlCommands);

}  // namespace
}  // namespace hdrstereo::proc
