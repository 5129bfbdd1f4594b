// SPDX-License-Identifier: GPL-3.0-or-later
//
// stereo: the LDR middle exposure, the seven tone-mapped pairs and the HDR
// radiance matched (disparity/<method>.pfm, and the left-right check of
// each in disparity/<method>_lr.png). fusion: the seven tone-mapped
// disparities fused by mean, median and graph cut (disparity/mean.pfm,
// median.pfm, fused.pfm). The thesis experiment's matching and fusion
// (processing/experiment), with files between them.
#include <map>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/experiment/thesis_experiment.h"
#include "processing/io/image.h"
#include "processing/pipeline/steps.h"

namespace hdrstereo::pipeline {
namespace {

using experiment::Candidate;
using experiment::ExperimentOptions;
using experiment::Method;

std::string DisparityFile(Method m) {
  return absl::StrCat("disparity/", experiment::MethodName(m), ".pfm");
}
std::string ConsistencyFile(Method m) {
  return absl::StrCat("disparity/", experiment::MethodName(m), "_lr.png");
}

struct Matching {
  ExperimentOptions options;  // ldr_stereo and hdr_stereo
  int max_disparity = 0;
};

absl::Status RunStereo(const Matching& o, StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
  ASSIGN_OR_RETURN(const hdr::ExposureStack right, c.Stack(1));
  c.Info(absl::StrCat("stereo: disparities 0..", o.max_disparity));
  std::map<Method, experiment::StereoPair> pairs;
  pairs[Method::kLdr] = {left.images[c.LdrIndex()], right.images[c.LdrIndex()]};
  for (Method m : experiment::ToneMappedMethods()) {
    const std::string folder =
        absl::StrCat("tonemapped/", experiment::MethodName(m), "/");
    ASSIGN_OR_RETURN(pairs[m].left, c.Read(folder + "im0.png"));
    ASSIGN_OR_RETURN(pairs[m].right, c.Read(folder + "im1.png"));
  }
  ASSIGN_OR_RETURN(pairs[Method::kHdr].left, c.ReadPfm("hdr/im0.pfm"));
  ASSIGN_OR_RETURN(pairs[Method::kHdr].right, c.ReadPfm("hdr/im1.pfm"));
  ASSIGN_OR_RETURN(const auto candidates,
                   experiment::MatchAllMethods(pairs, o.max_disparity,
                                               o.options, c.Units()));
  for (Method m : experiment::MatchedMethods()) {
    const Candidate& d = candidates.at(m);
    RETURN_IF_ERROR(
        c.outputs().WriteImage("disparity", DisparityFile(m), d.disparity));
    if (!d.consistent.empty()) {
      RETURN_IF_ERROR(c.outputs().WriteImage("disparity", ConsistencyFile(m),
                                             d.consistent));
    }
  }
  return absl::OkStatus();
}

struct Fusion {
  ExperimentOptions options;  // fusion, robust_fusion, inconsistent_confidence
  int max_disparity = 0;
};

absl::Status RunFusion(const Fusion& o, StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
  std::map<Method, Candidate> candidates;
  for (Method m : experiment::ToneMappedMethods()) {
    ASSIGN_OR_RETURN(candidates[m].disparity, c.ReadPfm(DisparityFile(m)));
    if (std::filesystem::exists(c.dir() / ConsistencyFile(m))) {
      ASSIGN_OR_RETURN(candidates[m].consistent, c.Read(ConsistencyFile(m)));
    }
  }
  ASSIGN_OR_RETURN(
      const experiment::Fused fused,
      experiment::FuseMethods(candidates, io::To8Bit(left.images[c.LdrIndex()]),
                              o.max_disparity, o.options, c.Units()));
  for (Method m : experiment::FusedMethods()) {
    RETURN_IF_ERROR(c.outputs().WriteImage("disparity", DisparityFile(m),
                                           fused.disparity.at(m)));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<ConfiguredStep> ConfigureStereo(const StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
  Matching o;
  o.options.ldr_stereo = c.options().experiment.ldr_stereo;
  o.options.hdr_stereo = c.options().experiment.hdr_stereo;
  ASSIGN_OR_RETURN(o.max_disparity, c.MaxDisparity(left.images[0].cols));
  return ConfiguredStep{{{"ldr_stereo", o.options.ldr_stereo},
                         {"hdr_stereo", o.options.hdr_stereo},
                         {"max_disparity", o.max_disparity},
                         {"ldr_exposure_s", left.exposure_s[c.LdrIndex()]}},
                        [o](StepContext& c) { return RunStereo(o, c); }};
}

absl::StatusOr<ConfiguredStep> ConfigureFusion(const StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
  Fusion o;
  o.options.fusion = c.options().experiment.fusion;
  o.options.robust_fusion = c.options().experiment.robust_fusion;
  o.options.inconsistent_confidence =
      c.options().experiment.inconsistent_confidence;
  ASSIGN_OR_RETURN(o.max_disparity, c.MaxDisparity(left.images[0].cols));
  return ConfiguredStep{
      {{"fusion", o.options.fusion},
       {"robust_fusion", o.options.robust_fusion},
       {"inconsistent_confidence", o.options.inconsistent_confidence},
       {"max_disparity", o.max_disparity}},
      [o](StepContext& c) { return RunFusion(o, c); }};
}

}  // namespace hdrstereo::pipeline
