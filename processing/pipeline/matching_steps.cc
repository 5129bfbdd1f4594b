// SPDX-License-Identifier: GPL-3.0-or-later
//
// stereo: the LDR middle exposure, the seven tone-mapped pairs and the HDR
// radiance matched (disparity/<method>.pfm). fusion: the seven tone-mapped
// disparities fused by mean, median and graph cut (disparity/mean.pfm,
// median.pfm, fused.pfm).
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/fusion/fusion.h"
#include "processing/io/image.h"
#include "processing/pipeline/steps.h"
#include "processing/stereo/cost_volume_stereo.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::pipeline {
namespace {

std::vector<std::string> OperatorNames() {
  std::vector<std::string> out;
  for (tonemap::Operator op : tonemap::AllOperators()) {
    out.push_back(tonemap::OperatorName(op));
  }
  return out;
}

// Matched methods (stereo step), then the fused ones (fusion step).
std::vector<std::string> StereoMethods() {
  std::vector<std::string> out = {"ldr"};
  for (const std::string& op : OperatorNames()) out.push_back(op);
  out.push_back("hdr");
  return out;
}

const std::vector<std::string>& FusedMethods() {
  static const std::vector<std::string>* m =
      new std::vector<std::string>{"mean", "median", "fused"};
  return *m;
}

struct StereoStep {
  stereo::StereoOptions ldr, hdr;  // the range set, one thread each
};

absl::Status RunStereo(const StereoStep& o, StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::ExposureStack left_stack, c.Stack(0));
  ASSIGN_OR_RETURN(const hdr::ExposureStack right_stack, c.Stack(1));
  c.Info(absl::StrCat("stereo: disparities 0..", o.ldr.max_disparity));
  const std::vector<std::string> methods = StereoMethods();
  return c.ParallelFor(methods, [&](int i, StepOutputs& out) -> absl::Status {
    const std::string& m = methods[static_cast<size_t>(i)];
    cv::Mat left, right;
    if (m == "ldr") {
      left = left_stack.images[c.LdrIndex()];
      right = right_stack.images[c.LdrIndex()];
    } else if (m == "hdr") {
      ASSIGN_OR_RETURN(left, c.ReadPfm("hdr/im0.pfm"));
      ASSIGN_OR_RETURN(right, c.ReadPfm("hdr/im1.pfm"));
    } else {
      ASSIGN_OR_RETURN(left,
                       c.Read(absl::StrCat("tonemapped/", m, "/im0.png")));
      ASSIGN_OR_RETURN(right,
                       c.Read(absl::StrCat("tonemapped/", m, "/im1.png")));
    }
    absl::StatusOr<stereo::StereoResult> d =
        stereo::ComputeDisparity(left, right, m == "hdr" ? o.hdr : o.ldr);
    if (!d.ok()) {
      return absl::Status(
          d.status().code(),
          absl::StrCat("stereo ", m, ": ", d.status().message()));
    }
    return out.WriteImage("disparity", absl::StrCat("disparity/", m, ".pfm"),
                          d->disparity);
  });
}

absl::Status RunFusion(const fusion::FusionParams& params, StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
  std::vector<cv::Mat> candidates;
  for (const std::string& op : OperatorNames()) {
    ASSIGN_OR_RETURN(cv::Mat d,
                     c.ReadPfm(absl::StrCat("disparity/", op, ".pfm")));
    candidates.push_back(d);
  }
  // The guide: the LDR middle exposure's left view (Appendix A: left.jpg).
  const cv::Mat guide = io::To8Bit(left.images[c.LdrIndex()]);
  const std::vector<std::string>& methods = FusedMethods();
  return c.ParallelFor(methods, [&](int i, StepOutputs& out) -> absl::Status {
    const std::string& m = methods[static_cast<size_t>(i)];
    cv::Mat d;
    if (m == "mean") {
      ASSIGN_OR_RETURN(d, fusion::FuseMean(candidates, params.max_disp));
    } else if (m == "median") {
      ASSIGN_OR_RETURN(d, fusion::FuseMedian(candidates, params.max_disp));
    } else {
      ASSIGN_OR_RETURN(const fusion::FusionResult r,
                       fusion::FuseAlphaExpansion(candidates, guide, params));
      d = r.disparity;
    }
    return out.WriteImage("disparity", absl::StrCat("disparity/", m, ".pfm"),
                          d);
  });
}

}  // namespace

absl::StatusOr<ConfiguredStep> ConfigureStereo(const StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
  ASSIGN_OR_RETURN(const int max_disp, c.MaxDisparity(left.images[0].cols));
  StereoStep o{c.options().ldr_stereo, c.options().hdr_stereo};
  for (stereo::StereoOptions* s : {&o.ldr, &o.hdr}) {
    s->max_disparity = max_disp;
    // One thread per matching: the matchings themselves run in parallel,
    // and the result does not depend on the split.
    s->threads = 1;
  }
  return ConfiguredStep{{{"ldr", o.ldr},
                         {"hdr", o.hdr},
                         {"ldr_exposure_s", left.exposure_s[c.LdrIndex()]}},
                        [o](StepContext& c) { return RunStereo(o, c); }};
}

absl::StatusOr<ConfiguredStep> ConfigureFusion(const StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::ExposureStack left, c.Stack(0));
  fusion::FusionParams params = c.options().fusion;
  ASSIGN_OR_RETURN(params.max_disp, c.MaxDisparity(left.images[0].cols));
  return ConfiguredStep{
      params, [params](StepContext& c) { return RunFusion(params, c); }};
}

}  // namespace hdrstereo::pipeline
