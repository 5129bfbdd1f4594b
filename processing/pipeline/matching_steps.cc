// SPDX-License-Identifier: GPL-3.0-or-later
//
// stereo: the LDR middle exposure, the seven tone-mapped pairs and the HDR
// radiance matched (disparity/<method>.pfm, and the left-right check of
// each in disparity/<method>_lr.png). fusion: the seven tone-mapped
// disparities fused by mean, median and graph cut (disparity/mean.pfm,
// median.pfm, fused.pfm). The thesis experiment's matching and fusion
// (processing/experiment), with files between them.
//
// Pairs wider than ExperimentOptions::matching_width are matched and fused
// at that width; disparity/ then holds the maps brought back to the
// images' size and disparity/matching/ the maps as matched, which fusion
// reads.
#include <map>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
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

// `folder` is "disparity/" (at the images' size) or kMatchingFolder.
constexpr char kImageFolder[] = "disparity/";
constexpr char kMatchingFolder[] = "disparity/matching/";
std::string DisparityFile(Method m, const char* folder = kImageFolder) {
  return absl::StrCat(folder, experiment::MethodName(m), ".pfm");
}
std::string ConsistencyFile(Method m, const char* folder = kImageFolder) {
  return absl::StrCat(folder, experiment::MethodName(m), "_lr.png");
}

// Where both steps match: the images' size and the working size.
struct Sizes {
  cv::Size image;
  cv::Size matching;
  int max_disparity = 0;  // at the matching size
  bool scaled() const { return matching != image; }
};

absl::StatusOr<Sizes> SizesOf(const StepContext& c, cv::Size image) {
  Sizes s;
  s.image = image;
  s.matching =
      experiment::MatchingSize(image, c.options().experiment.matching_width);
  ASSIGN_OR_RETURN(
      s.max_disparity,
      c.MaxDisparity(s.matching.width,
                     static_cast<double>(s.matching.width) / image.width));
  return s;
}

nlohmann::json ToJson(const Sizes& s) {
  return {{"max_disparity", s.max_disparity},
          {"matching_size", {s.matching.width, s.matching.height}}};
}

// A map at the matching size written where later steps read it: as it is
// under disparity/matching/ when scaled, and at the images' size under
// disparity/.
absl::Status WriteMap(StepContext& c, const Sizes& sizes,
                      const std::string& image_rel,
                      const std::string& matching_rel, const cv::Mat& map) {
  if (sizes.scaled()) {
    RETURN_IF_ERROR(c.outputs().WriteImage("disparity", matching_rel, map));
  }
  return c.outputs().WriteImage("disparity", image_rel,
                                experiment::ToImageSize(map, sizes.image));
}

struct Matching {
  ExperimentOptions options;  // ldr_stereo and hdr_stereo
  Sizes sizes;
};

absl::Status RunStereo(const Matching& o, StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::StackImage left, c.Ldr(0));
  ASSIGN_OR_RETURN(const hdr::StackImage right, c.Ldr(1));
  const cv::Size at = o.sizes.matching;
  c.Info(absl::StrCat("stereo: disparities 0..", o.sizes.max_disparity,
                      o.sizes.scaled()
                          ? absl::StrCat(" at ", at.width, " x ", at.height,
                                         " (matching_width)")
                          : ""));
  std::map<Method, experiment::StereoPair> pairs;
  const auto add = [&](Method m, const cv::Mat& l, const cv::Mat& r) {
    pairs[m] = {experiment::ToMatchingSize(l, at),
                experiment::ToMatchingSize(r, at)};
  };
  add(Method::kLdr, left.image, right.image);
  for (Method m : experiment::ToneMappedMethods()) {
    ASSIGN_OR_RETURN(const cv::Mat l, c.Read(ToneMappedFile(m, 0)));
    ASSIGN_OR_RETURN(const cv::Mat r, c.Read(ToneMappedFile(m, 1)));
    add(m, l, r);
  }
  ASSIGN_OR_RETURN(const cv::Mat hdr_left, c.ReadPfm("hdr/im0.pfm"));
  ASSIGN_OR_RETURN(const cv::Mat hdr_right, c.ReadPfm("hdr/im1.pfm"));
  add(Method::kHdr, hdr_left, hdr_right);
  ASSIGN_OR_RETURN(const auto candidates,
                   experiment::MatchAllMethods(pairs, o.sizes.max_disparity,
                                               o.options, c.Units()));
  for (Method m : experiment::MatchedMethods()) {
    const Candidate& d = candidates.at(m);
    RETURN_IF_ERROR(WriteMap(c, o.sizes, DisparityFile(m),
                             DisparityFile(m, kMatchingFolder), d.disparity));
    if (!d.consistent.empty()) {
      RETURN_IF_ERROR(WriteMap(c, o.sizes, ConsistencyFile(m),
                               ConsistencyFile(m, kMatchingFolder),
                               d.consistent));
    }
  }
  return absl::OkStatus();
}

struct Fusion {
  ExperimentOptions options;  // fusion, robust_fusion, inconsistent_confidence
  Sizes sizes;
};

absl::Status RunFusion(const Fusion& o, StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::StackImage left, c.Ldr(0));
  const char* folder = o.sizes.scaled() ? kMatchingFolder : kImageFolder;
  std::map<Method, Candidate> candidates;
  for (Method m : experiment::ToneMappedMethods()) {
    ASSIGN_OR_RETURN(candidates[m].disparity,
                     c.ReadPfm(DisparityFile(m, folder)));
    if (std::filesystem::exists(c.dir() / ConsistencyFile(m, folder))) {
      ASSIGN_OR_RETURN(candidates[m].consistent,
                       c.Read(ConsistencyFile(m, folder)));
    }
  }
  experiment::FusionViews views;
  views.guide =
      experiment::ToMatchingSize(io::To8Bit(left.image), o.sizes.matching);
  const fusion::ReliabilityOptions& robust = o.options.robust_fusion;
  // The plane prior segments the left view; the photo-consistency choice
  // matches both.
  if (robust.enabled && (robust.planes.enabled || robust.photo.enabled)) {
    ASSIGN_OR_RETURN(const cv::Mat left_view,
                     c.Read(ToneMappedFile(experiment::kFusionView, 0)));
    views.left = experiment::ToMatchingSize(left_view, o.sizes.matching);
  }
  if (robust.enabled && robust.photo.enabled) {
    ASSIGN_OR_RETURN(const cv::Mat right_view,
                     c.Read(ToneMappedFile(experiment::kFusionView, 1)));
    views.right = experiment::ToMatchingSize(right_view, o.sizes.matching);
  }
  ASSIGN_OR_RETURN(
      const experiment::Fused fused,
      experiment::FuseMethods(candidates, views, o.sizes.max_disparity,
                              o.options, c.Units()));
  if (robust.enabled) {
    const fusion::RefinementCounts& r = fused.refinement;
    c.Info(absl::StrFormat(
        "fusion: planes on %d of %d segments (%.2f %% of the pixels), "
        "photo-consistency choice %.2f %%, speckle filter %.2f %%",
        r.planes, r.segments, 100 * r.plane_fraction, 100 * r.photo_fraction,
        100 * r.speckle_fraction));
  }
  for (Method m : experiment::FusedMethods()) {
    RETURN_IF_ERROR(WriteMap(c, o.sizes, DisparityFile(m),
                             DisparityFile(m, kMatchingFolder),
                             fused.disparity.at(m)));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<ConfiguredStep> ConfigureStereo(const StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::StackImage left, c.Ldr(0));
  Matching o;
  o.options.ldr_stereo = c.options().experiment.ldr_stereo;
  o.options.hdr_stereo = c.options().experiment.hdr_stereo;
  ASSIGN_OR_RETURN(o.sizes, SizesOf(c, left.image.size()));
  return ConfiguredStep{{{"ldr_stereo", o.options.ldr_stereo},
                         {"hdr_stereo", o.options.hdr_stereo},
                         {"sizes", ToJson(o.sizes)},
                         {"ldr_exposure_s", left.exposure_s}},
                        [o](StepContext& c) { return RunStereo(o, c); }};
}

absl::StatusOr<ConfiguredStep> ConfigureFusion(const StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::StackImage left, c.Ldr(0));
  Fusion o;
  o.options.fusion = c.options().experiment.fusion;
  o.options.robust_fusion = c.options().experiment.robust_fusion;
  o.options.inconsistent_confidence =
      c.options().experiment.inconsistent_confidence;
  ASSIGN_OR_RETURN(o.sizes, SizesOf(c, left.image.size()));
  return ConfiguredStep{
      {{"fusion", o.options.fusion},
       {"robust_fusion", o.options.robust_fusion},
       {"inconsistent_confidence", o.options.inconsistent_confidence},
       {"sizes", ToJson(o.sizes)}},
      [o](StepContext& c) { return RunFusion(o, c); }};
}

}  // namespace hdrstereo::pipeline
