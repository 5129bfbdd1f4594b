// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc response --stack DIR [--out FILE]
// hdrstereo-proc merge --stack DIR --out FILE.exr [--response FILE] ...
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"
#include "processing/hdr/stack.h"
#include "processing/io/hdr_formats.h"

namespace hdrstereo::proc {
namespace {

struct ResponseArgs {
  std::string stack;
  std::string out;
  double lambda = 10;
  int samples = 120;
};

struct MergeArgs {
  std::string stack;
  std::string out;
  std::string response;
  std::string rgbe;
  std::string luminance;
  std::string log_luminance;
  std::string mask;
  bool half = true;
};

absl::Status RunResponse(const ResponseArgs& args) {
  ASSIGN_OR_RETURN(hdr::ExposureStack stack, hdr::LoadStack(args.stack));
  hdr::ResponseOptions options;
  options.lambda = args.lambda;
  options.samples = args.samples;
  ASSIGN_OR_RETURN(hdr::CameraResponse response,
                   hdr::RecoverResponse(stack, options));
  const std::filesystem::path out =
      args.out.empty() ? std::filesystem::path(args.stack) / "response.yml"
                       : std::filesystem::path(args.out);
  RETURN_IF_ERROR(hdr::SaveResponse(out, response));
  const cv::Mat& g = response.log_inverse;
  std::cout << "response of " << stack.images.size() << " exposures ("
            << g.channels() << " channels) written to " << out.string() << "\n";
  for (int z : {16, 64, 128, 192, 239}) {
    std::cout << "  g(" << z << ") =";
    for (int c = 0; c < g.channels(); ++c) {
      std::cout << " " << g.ptr<float>(z)[c];
    }
    std::cout << "\n";
  }
  return absl::OkStatus();
}

absl::Status RunMerge(const MergeArgs& args) {
  ASSIGN_OR_RETURN(hdr::ExposureStack stack, hdr::LoadStack(args.stack));
  hdr::CameraResponse response;
  if (!args.response.empty()) {
    ASSIGN_OR_RETURN(hdr::CameraResponse loaded,
                     hdr::LoadResponse(args.response));
    response = std::move(loaded);
  } else if (stack.images[0].depth() != CV_8U) {
    response = hdr::LinearResponse(stack.camera);  // 16-bit/float RAW
  } else {
    ASSIGN_OR_RETURN(hdr::CameraResponse recovered,
                     hdr::RecoverResponse(stack));
    response = std::move(recovered);
  }
  ASSIGN_OR_RETURN(hdr::MergeResult merged, hdr::MergeStack(stack, response));
  RETURN_IF_ERROR(io::WriteExr(
      args.out, merged.radiance,
      args.half ? io::ExrPixelType::kHalf : io::ExrPixelType::kFloat));
  if (!args.rgbe.empty()) {
    RETURN_IF_ERROR(io::WriteRgbe(args.rgbe, merged.radiance));
  }
  if (!args.luminance.empty()) {
    RETURN_IF_ERROR(
        io::WriteImage(args.luminance, hdr::Luminance(merged.radiance)));
  }
  if (!args.log_luminance.empty()) {
    RETURN_IF_ERROR(
        io::WriteImage(args.log_luminance, hdr::LogLuminance(merged.radiance)));
  }
  if (!args.mask.empty()) {
    RETURN_IF_ERROR(io::WritePng(args.mask, merged.mask));
  }
  double lo = 0, hi = 0;
  cv::Mat lum = hdr::Luminance(merged.radiance);
  cv::minMaxLoc(lum, &lo, &hi, nullptr, nullptr, merged.mask == 0);
  std::cout << "merged " << stack.images.size() << " exposures into "
            << args.out << ": luminance " << lo << " .. " << hi
            << " (dynamic range " << (lo > 0 ? hi / lo : 0) << ":1), "
            << merged.saturated_pixels
            << " pixels saturated in every exposure, " << merged.dark_pixels
            << " dark in every exposure\n";
  return absl::OkStatus();
}

void AddHdrCommands(CLI::App& app) {
  auto r = std::make_shared<ResponseArgs>();
  CLI::App* response = app.add_subcommand(
      "response", "recover the camera response (Debevec & Malik) of a stack");
  response
      ->add_option("--stack", r->stack,
                   "folder of exposures (+ exposures.txt or EXIF times)")
      ->required();
  response->add_option("--out", r->out,
                       "response file (default: <stack>/response.yml)");
  response->add_option("--lambda", r->lambda, "smoothness weight")
      ->check(CLI::NonNegativeNumber);
  response->add_option("--samples", r->samples, "pixels sampled per channel")
      ->check(CLI::Range(2, 100000));
  response->callback([r] { SetOutcome(RunResponse(*r)); });

  auto m = std::make_shared<MergeArgs>();
  CLI::App* merge =
      app.add_subcommand("merge", "merge an exposure stack into radiance");
  merge->add_option("--stack", m->stack, "folder of exposures")->required();
  merge->add_option("--out", m->out, "radiance output (.exr)")->required();
  merge->add_option("--response", m->response,
                    "camera response file (default: recover it from the "
                    "stack for 8-bit images, linear for 16-bit/RAW)");
  merge->add_option("--hdr", m->rgbe, "also write Radiance RGBE (.hdr)");
  merge->add_option("--luminance", m->luminance,
                    "also write luminance (.pfm/.exr)");
  merge->add_option("--log-luminance", m->log_luminance,
                    "also write log10 luminance (.pfm/.exr)");
  merge->add_option("--mask", m->mask,
                    "also write the clipped-pixel mask (.png; 1 = saturated "
                    "in every exposure, 2 = dark in every exposure)");
  merge->add_flag("!--float", m->half,
                  "write 32-bit float EXR instead of half");
  merge->callback([m] { SetOutcome(RunMerge(*m)); });
}

const CommandGroup kHdrGroup("hdr", &AddHdrCommands);

}  // namespace
}  // namespace hdrstereo::proc
