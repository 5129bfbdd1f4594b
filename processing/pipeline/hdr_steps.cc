// SPDX-License-Identifier: GPL-3.0-or-later
//
// response: the left stack's camera response (hdr/response.yml). hdr: both
// views merged (hdr/im0.pfm, im1.pfm). tonemap: the pair tone-mapped with
// each of the seven operators (tonemapped/<op>/im0.png, im1.png). The
// thesis experiment's first three stages (processing/experiment).
#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/experiment/thesis_experiment.h"
#include "processing/hdr/response.h"
#include "processing/io/capture_layout.h"
#include "processing/pipeline/steps.h"

namespace hdrstereo::pipeline {
namespace {

using experiment::ExperimentOptions;
using experiment::Method;
constexpr char kResponseFile[] = "hdr/response.yml";

}  // namespace

absl::StatusOr<ConfiguredStep> ConfigureResponse(const StepContext& c) {
  ExperimentOptions o;
  o.response = c.options().experiment.response;
  return ConfiguredStep{
      o.response, [o](StepContext& c) -> absl::Status {
        ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
        ASSIGN_OR_RETURN(const hdr::CameraResponse response,
                         experiment::ResponseOf(left, o));
        return c.outputs().Write("response", kResponseFile,
                                 [&](const std::filesystem::path& path) {
                                   return hdr::SaveResponse(path, response);
                                 });
      }};
}

absl::StatusOr<ConfiguredStep> ConfigureHdr(const StepContext& c) {
  ExperimentOptions o;
  o.merge = c.options().experiment.merge;
  return ConfiguredStep{
      o.merge, [o](StepContext& c) -> absl::Status {
        ASSIGN_OR_RETURN(const hdr::CameraResponse response,
                         hdr::LoadResponse(c.dir() / kResponseFile));
        for (int v = 0; v < 2; ++v) {
          ASSIGN_OR_RETURN(const hdr::ExposureStack stack, c.Stack(v));
          ASSIGN_OR_RETURN(const cv::Mat radiance,
                           experiment::RadianceOf(stack, response, o));
          RETURN_IF_ERROR(c.outputs().WriteImage(
              "hdr", absl::StrCat("hdr/im", v, ".pfm"), radiance));
          c.Progress(v + 1, 2, absl::StrCat("hdr: ", io::ViewName(v)));
        }
        return absl::OkStatus();
      }};
}

std::string ToneMappedFile(Method m, int view) {
  return absl::StrCat("tonemapped/", experiment::MethodName(m), "/im", view,
                      ".png");
}

absl::StatusOr<ConfiguredStep> ConfigureTonemap(const StepContext& c) {
  ExperimentOptions o;
  o.tonemap = c.options().experiment.tonemap;
  std::vector<std::string> names;
  for (Method m : experiment::ToneMappedMethods()) {
    names.push_back(experiment::MethodName(m));
  }
  return ConfiguredStep{
      {{"operators", names}, {"params", o.tonemap}},
      [o, names](StepContext& c) -> absl::Status {
        ASSIGN_OR_RETURN(const cv::Mat left, c.ReadPfm("hdr/im0.pfm"));
        ASSIGN_OR_RETURN(const cv::Mat right, c.ReadPfm("hdr/im1.pfm"));
        return c.ParallelFor(
            names, [&](int i, StepOutputs& out) -> absl::Status {
              const Method m =
                  experiment::ToneMappedMethods()[static_cast<size_t>(i)];
              ASSIGN_OR_RETURN(const experiment::StereoPair pair,
                               experiment::ToneMapped(m, left, right, o));
              RETURN_IF_ERROR(out.WriteImage("tonemapped", ToneMappedFile(m, 0),
                                             pair.left));
              return out.WriteImage("tonemapped", ToneMappedFile(m, 1),
                                    pair.right);
            });
      }};
}

}  // namespace hdrstereo::pipeline
