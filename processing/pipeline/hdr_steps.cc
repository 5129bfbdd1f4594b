// SPDX-License-Identifier: GPL-3.0-or-later
//
// response: the left stack's camera response (hdr/response.yml). hdr: both
// views merged (hdr/im0.pfm, im1.pfm). tonemap: the pair tone-mapped with
// each of the seven operators (tonemapped/<op>/im0.png, im1.png).
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"
#include "processing/io/capture_layout.h"
#include "processing/pipeline/steps.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::pipeline {
namespace {

constexpr char kResponseFile[] = "hdr/response.yml";

}  // namespace

absl::StatusOr<ConfiguredStep> ConfigureResponse(const StepContext& c) {
  const hdr::ResponseOptions options = c.options().response;
  return ConfiguredStep{
      options, [options](StepContext& c) -> absl::Status {
        ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
        ASSIGN_OR_RETURN(const hdr::CameraResponse response,
                         left.images[0].depth() == CV_8U
                             ? hdr::RecoverResponse(left, options)
                             : hdr::LinearResponse(left.camera));
        return c.outputs().Write("response", kResponseFile,
                                 [&](const std::filesystem::path& path) {
                                   return hdr::SaveResponse(path, response);
                                 });
      }};
}

absl::StatusOr<ConfiguredStep> ConfigureHdr(const StepContext& c) {
  const hdr::MergeOptions options = c.options().merge;
  return ConfiguredStep{
      options, [options](StepContext& c) -> absl::Status {
        ASSIGN_OR_RETURN(const hdr::CameraResponse response,
                         hdr::LoadResponse(c.dir() / kResponseFile));
        for (int v = 0; v < 2; ++v) {
          ASSIGN_OR_RETURN(const hdr::ExposureStack stack, c.Stack(v));
          ASSIGN_OR_RETURN(const hdr::MergeResult merged,
                           hdr::MergeStack(stack, response, options));
          cv::Mat radiance = merged.radiance;
          if (radiance.channels() == 1) {
            cv::cvtColor(radiance, radiance, cv::COLOR_GRAY2BGR);
          }
          RETURN_IF_ERROR(c.outputs().WriteImage(
              "hdr", absl::StrCat("hdr/im", v, ".pfm"), radiance));
          c.Progress(v + 1, 2, absl::StrCat("hdr: ", io::ViewName(v)));
        }
        return absl::OkStatus();
      }};
}

absl::StatusOr<ConfiguredStep> ConfigureTonemap(const StepContext& c) {
  const tonemap::Params params = c.options().tonemap;
  std::vector<std::string> names;
  for (tonemap::Operator op : tonemap::AllOperators()) {
    names.push_back(tonemap::OperatorName(op));
  }
  return ConfiguredStep{
      {{"operators", names}, {"params", params}},
      [params, names](StepContext& c) -> absl::Status {
        ASSIGN_OR_RETURN(const cv::Mat left, c.ReadPfm("hdr/im0.pfm"));
        ASSIGN_OR_RETURN(const cv::Mat right, c.ReadPfm("hdr/im1.pfm"));
        const std::vector<tonemap::Operator> ops = tonemap::AllOperators();
        return c.ParallelFor(
            names, [&](int i, StepOutputs& out) -> absl::Status {
              const size_t k = static_cast<size_t>(i);
              ASSIGN_OR_RETURN(
                  const auto pair,
                  tonemap::ToneMapPair(left, right, ops[k], params));
              const std::string folder =
                  absl::StrCat("tonemapped/", names[k], "/");
              RETURN_IF_ERROR(
                  out.WriteImage("tonemapped", folder + "im0.png", pair.first));
              return out.WriteImage("tonemapped", folder + "im1.png",
                                    pair.second);
            });
      }};
}

}  // namespace hdrstereo::pipeline
