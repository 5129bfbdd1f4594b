// SPDX-License-Identifier: GPL-3.0-or-later
//
// The thesis experiment (ch. 5, Tables 5.2 / 5.3), once: camera response
// from the left stack -> HDR radiance per view -> the pair tone-mapped with
// each of the seven operators -> the LDR middle exposure, the seven pairs
// and the radiance matched (cost-volume filtering) -> the seven tone-mapped
// disparities fused (mean, median, graph cut) -> every method scored on the
// non-occluded pixels of a truth.
//
// The session pipeline runs these stages as its steps (with files between
// them) and hdrstereo-proc table (thesis_table.h) runs them in memory; both
// call the functions here with the same ExperimentOptions, so a processed
// session's metrics and the table agree on the same input by construction.
#ifndef HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_EXPERIMENT_H_
#define HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_EXPERIMENT_H_

#include <functional>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "processing/eval/disparity_eval.h"
#include "processing/experiment/method.h"
#include "processing/fusion/fusion.h"
#include "processing/fusion/reliability.h"
#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"
#include "processing/hdr/stack.h"
#include "processing/stereo/cost_volume_stereo.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::experiment {

struct ExperimentOptions {
  hdr::ResponseOptions response;  // Debevec & Malik, 8-bit stacks
  hdr::MergeOptions merge;
  tonemap::Params tonemap;  // all seven operators
  // ldr and the tone-mapped pairs; hdr. Their disparity range and thread
  // count are set per run (DisparityRange; one thread a matching).
  stereo::StereoOptions ldr_stereo;
  stereo::StereoOptions hdr_stereo = stereo::StereoOptions::Hdr();
  // The graph-cut fusion; max_disp is set per run like the stereo range.
  fusion::FusionOptions fusion;
  // By default each candidate is weighed by its own evidence
  // (fusion/reliability.h; its sigma replaces fusion.sigma);
  // robust_fusion.enabled = false is the thesis' fusion, one cut with the
  // weights below.
  fusion::ReliabilityOptions robust_fusion;
  // Thesis fusion only: candidates' pixels that fail their left-right check
  // get this confidence in the data term (1 = ignore the check). Default 1:
  // on the simulated scenes down-weighting inconsistent pixels made that
  // fusion worse (lab-lamp, 256 px: fused-7 RMSE 0.71 at 1, 1.72 at 0.25,
  // 2.84 at 0.05) -- the failing TMOs' errors are often left-right
  // consistent.
  double inconsistent_confidence = 1.0;
  // Scoring; the bad-pixel thresholds are 0.5, 1, 2 and 4 px.
  eval::EvalOptions evaluation{.gt_zero_valid = true};
  // The session pipeline matches and fuses pairs wider than this resized
  // to this width (area average), and brings the disparities back to the
  // images' size (MatchingSize, ToImageSize); 0 = always at full size. In
  // pixels: a time and memory budget, not a property of the scene
  // (matching costs width x height x disparity range, cubic in the width).
  // 1600 keeps a 24-megapixel session within the 10 minutes on 2 cores of
  // docs/results.md ("Sessions from 24-megapixel cameras") and leaves the
  // bundled scenes (1200 px) at full size. The table matches at its own
  // sizes and ignores it.
  int matching_width = 1600;

  // INVALID_ARGUMENT naming the first field that breaks a rule ("fusion.
  // sigma is 0; ..."); the fields set per run are not judged.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const ExperimentOptions& o);

// Runs unit(i) for i < names.size() (a matching, a fusion), possibly in
// parallel; the pipeline's runs check for cancellation and report progress
// by name. SerialRunner runs them in order on the caller's thread.
using UnitRunner =
    std::function<absl::Status(const std::vector<std::string>& names,
                               const std::function<absl::Status(int)>& unit)>;
absl::Status SerialRunner(const std::vector<std::string>& names,
                          const std::function<absl::Status(int)>& unit);

// The disparity range of a data set whose largest true disparity is
// `largest` (<= 0: no truth): ceil(largest) + 2, or 64 without truth; at
// most width - 2 (every disparity must stay inside the image). Matched at
// `scale` of the size the truth has (a working size, `width` wide):
// ceil(largest x scale) + 2, or 64 x scale, the same range in the images'
// pixels.
double LargestDisparity(const cv::Mat& truth);  // finite values; 0 if none
int DisparityRange(double largest, int width, double scale = 1.0);

// Matching at a working size (ExperimentOptions::matching_width): the size
// an `image`-sized pair is matched at, `image` itself when it is not wider
// than `matching_width` or that is 0; the height keeps the aspect ratio.
cv::Size MatchingSize(cv::Size image, int matching_width);
// `image` resized to `size` by area averaging (itself when the size is
// already that).
cv::Mat ToMatchingSize(const cv::Mat& image, cv::Size size);
// A disparity (CV_32FC1) found at its own size, brought to `image`'s size:
// bilinear, values times image.width / its width. A left-right check mask
// (CV_8UC1) is resized by nearest neighbour, values unchanged.
cv::Mat ToImageSize(const cv::Mat& map, cv::Size image);

// 1. The camera response of the left stack: recovered for 8-bit data,
// linear for 16-bit / float (RAW).
absl::StatusOr<hdr::CameraResponse> ResponseOf(
    const hdr::ExposureStack& left, const ExperimentOptions& options);
// 2. A view's radiance, always BGR (grey stacks are replicated).
absl::StatusOr<cv::Mat> RadianceOf(const hdr::ExposureStack& stack,
                                   const hdr::CameraResponse& response,
                                   const ExperimentOptions& options);

struct StereoPair {
  cv::Mat left, right;
};
// 3. A tone-mapped method's pair from the two radiance maps.
absl::StatusOr<StereoPair> ToneMapped(Method method, const cv::Mat& left,
                                      const cv::Mat& right,
                                      const ExperimentOptions& options);

// 4. Matching. Each matched method's pair: `ldr` the LDR middle exposure,
// the tone-mapped ones their 8-bit pairs, `hdr` the radiance.
struct Candidate {
  cv::Mat disparity;   // CV_32FC1, every pixel filled
  cv::Mat consistent;  // CV_8UC1, 255 where the left-right check passed
};
// Every method of `pairs` (keys of MatchedMethods()) matched over
// 0 .. max_disparity, one thread a matching, the matchings through
// `runner`. Errors name the method ("stereo reinhard: ...").
absl::StatusOr<std::map<Method, Candidate>> MatchAllMethods(
    const std::map<Method, StereoPair>& pairs, int max_disparity,
    const ExperimentOptions& options, const UnitRunner& runner = SerialRunner);

// 5. Fusion of the seven tone-mapped candidates (all of ToneMappedMethods()
// in `candidates`) into mean, median and fused. It looks at views, 8-bit
// and of the candidates' size: the smoothness term's guide, the LDR middle
// exposure's left view (Appendix A: left.jpg), and kFusionView's
// tone-mapped pair, where dark surfaces are visible, whose left view the
// reliability fusion's plane prior segments and whose two views its
// photo-consistency choice matches (the pair is unused by the thesis'
// fusion).
struct FusionViews {
  cv::Mat guide;
  cv::Mat left, right;
};
inline constexpr Method kFusionView = Method::kReinhard;
struct Fused {
  std::map<Method, cv::Mat> disparity;  // FusedMethods()
  fusion::SolverStats stats;            // of fused
  fusion::RefinementCounts refinement;  // of fused
};
absl::StatusOr<Fused> FuseMethods(const std::map<Method, Candidate>& candidates,
                                  const FusionViews& views, int max_disparity,
                                  const ExperimentOptions& options,
                                  const UnitRunner& runner = SerialRunner);
// Graph-cut fusion of some of the tone-mapped candidates (the table's
// fused-4 subsets): by reliability, or the thesis' one cut.
absl::StatusOr<fusion::FusionResult> FuseSome(
    const std::vector<const Candidate*>& candidates, const FusionViews& views,
    int max_disparity, const ExperimentOptions& options);

// 6. A disparity scored against a truth on its non-occluded pixels
// (`nonoccluded` empty = every pixel with a true disparity).
absl::StatusOr<eval::RegionMetrics> Score(const cv::Mat& disparity,
                                          const cv::Mat& truth,
                                          const cv::Mat& nonoccluded,
                                          const ExperimentOptions& options);

}  // namespace hdrstereo::experiment

#endif  // HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_EXPERIMENT_H_
