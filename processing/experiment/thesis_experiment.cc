// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/experiment/thesis_experiment.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::experiment {
namespace {

// Disparity range when there is no ground truth to take it from.
constexpr int kDefaultMaxDisparity = 64;
// Added to the largest true disparity.
constexpr int kDisparityMargin = 2;
// ExperimentOptions::matching_width: below 64 px nothing is left to match;
// above 16384 px the budget means nothing on any machine here.
constexpr int kMinMatchingWidth = 64;
constexpr int kMaxMatchingWidth = 16384;

std::vector<std::string> NamesOf(const std::vector<Method>& methods) {
  std::vector<std::string> out;
  for (Method m : methods) out.push_back(MethodName(m));
  return out;
}

// The fusion's data weight per pixel: 1 where the candidate passed its
// left-right check, `inconsistent` elsewhere.
cv::Mat ConfidenceOf(const Candidate& c, double inconsistent) {
  cv::Mat confidence(c.disparity.size(), CV_32FC1,
                     cv::Scalar(c.consistent.empty() ? 1.0 : inconsistent));
  if (!c.consistent.empty()) confidence.setTo(1.0f, c.consistent);
  return confidence;
}

fusion::FusionOptions FusionOf(const ExperimentOptions& o, int max_disparity) {
  fusion::FusionOptions p = o.fusion;
  p.max_disp = max_disparity;
  return p;
}

}  // namespace

absl::Status ExperimentOptions::Validate() const {
  RETURN_IF_ERROR(WithFieldPrefix("response", response.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("merge", merge.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("tonemap", tonemap.Validate()));
  // The disparity range and thread counts are set per run (any valid value
  // stands in for them here).
  for (const auto& [name, stereo] :
       {std::pair{"ldr_stereo", ldr_stereo}, {"hdr_stereo", hdr_stereo}}) {
    stereo::StereoOptions s = stereo;
    s.max_disparity = s.min_disparity + 1;
    s.threads = 1;
    RETURN_IF_ERROR(WithFieldPrefix(name, s.Validate()));
  }
  RETURN_IF_ERROR(WithFieldPrefix("fusion", FusionOf(*this, 1).Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("robust_fusion", robust_fusion.Validate()));
  RETURN_IF_ERROR(RequireField(
      inconsistent_confidence >= 0 && inconsistent_confidence <= 1,
      "inconsistent_confidence", inconsistent_confidence, "in [0, 1]"));
  RETURN_IF_ERROR(WithFieldPrefix("evaluation", evaluation.Validate()));
  if (evaluation.thresholds != std::vector<double>{0.5, 1, 2, 4}) {
    return absl::InvalidArgumentError(
        "evaluation.thresholds must be {0.5, 1, 2, 4}: the metrics' "
        "bad-pixel columns");
  }
  return RequireField(
      matching_width == 0 || (matching_width >= kMinMatchingWidth &&
                              matching_width <= kMaxMatchingWidth),
      "matching_width", matching_width,
      absl::StrCat("0 (full size) or in [", kMinMatchingWidth, ", ",
                   kMaxMatchingWidth, "]"));
}

void to_json(nlohmann::json& j, const ExperimentOptions& o) {
  const auto& [response, merge, tonemap, ldr_stereo, hdr_stereo, fusion,
               robust_fusion, inconsistent_confidence, evaluation,
               matching_width] = o;
  j = nlohmann::json{{"response", response},
                     {"merge", merge},
                     {"tonemap", tonemap},
                     {"ldr_stereo", ldr_stereo},
                     {"hdr_stereo", hdr_stereo},
                     {"fusion", fusion},
                     {"robust_fusion", robust_fusion},
                     {"inconsistent_confidence", inconsistent_confidence},
                     {"evaluation", evaluation},
                     {"matching_width", matching_width}};
}

absl::Status SerialRunner(const std::vector<std::string>& names,
                          const std::function<absl::Status(int)>& unit) {
  for (int i = 0; i < static_cast<int>(names.size()); ++i) {
    RETURN_IF_ERROR(unit(i));
  }
  return absl::OkStatus();
}

double LargestDisparity(const cv::Mat& truth) {
  cv::Mat finite = truth == truth;  // not NaN
  finite &= truth < std::numeric_limits<float>::infinity();
  if (cv::countNonZero(finite) == 0) return 0;
  double hi = 0;
  cv::minMaxLoc(truth, nullptr, &hi, nullptr, nullptr, finite);
  return hi;
}

int DisparityRange(double largest, int width, double scale) {
  const int range =
      largest > 0
          ? static_cast<int>(std::ceil(largest * scale)) + kDisparityMargin
          : static_cast<int>(std::ceil(kDefaultMaxDisparity * scale));
  return std::clamp(range, 1, std::max(1, width - 2));
}

cv::Size MatchingSize(cv::Size image, int matching_width) {
  if (matching_width <= 0 || image.width <= matching_width) return image;
  const int height = static_cast<int>(std::lround(
      static_cast<double>(image.height) * matching_width / image.width));
  return {matching_width, std::max(1, height)};
}

cv::Mat ToMatchingSize(const cv::Mat& image, cv::Size size) {
  if (image.size() == size) return image;
  cv::Mat out;
  cv::resize(image, out, size, 0, 0, cv::INTER_AREA);
  return out;
}

cv::Mat ToImageSize(const cv::Mat& map, cv::Size image) {
  if (map.size() == image) return map;
  cv::Mat out;
  if (map.depth() == CV_8U) {
    cv::resize(map, out, image, 0, 0, cv::INTER_NEAREST);
    return out;
  }
  cv::resize(map, out, image, 0, 0, cv::INTER_LINEAR);
  out *= static_cast<double>(image.width) / map.cols;
  return out;
}

absl::StatusOr<hdr::CameraResponse> ResponseOf(
    const hdr::ExposureStack& left, const ExperimentOptions& options) {
  if (left.images.empty() || left.images[0].depth() != CV_8U) {
    return hdr::LinearResponse(left.camera);
  }
  return hdr::RecoverResponse(left, options.response);
}

absl::StatusOr<cv::Mat> RadianceOf(const hdr::ExposureStack& stack,
                                   const hdr::CameraResponse& response,
                                   const ExperimentOptions& options) {
  ASSIGN_OR_RETURN(const hdr::MergeResult merged,
                   hdr::MergeStack(stack, response, options.merge));
  cv::Mat radiance = merged.radiance;
  if (radiance.channels() == 1) {
    cv::cvtColor(radiance, radiance, cv::COLOR_GRAY2BGR);
  }
  return radiance;
}

absl::StatusOr<StereoPair> ToneMapped(Method method, const cv::Mat& left,
                                      const cv::Mat& right,
                                      const ExperimentOptions& options) {
  const std::optional<tonemap::Operator> op = OperatorOf(method);
  if (!op) {
    return absl::InvalidArgumentError(
        absl::StrCat(MethodName(method), " is not a tone-mapped method"));
  }
  ASSIGN_OR_RETURN(auto pair,
                   tonemap::ToneMapPair(left, right, *op, options.tonemap));
  return StereoPair{pair.first, pair.second};
}

absl::StatusOr<std::map<Method, Candidate>> MatchAllMethods(
    const std::map<Method, StereoPair>& pairs, int max_disparity,
    const ExperimentOptions& options, const UnitRunner& runner) {
  std::vector<Method> methods;
  for (Method m : MatchedMethods()) {
    if (pairs.count(m)) methods.push_back(m);
  }
  if (methods.size() != pairs.size()) {
    return absl::InvalidArgumentError(
        "matching: only ldr, the tone-mapped methods and hdr are matched");
  }
  std::vector<Candidate> out(methods.size());
  RETURN_IF_ERROR(runner(NamesOf(methods), [&](int i) -> absl::Status {
    const Method m = methods[static_cast<size_t>(i)];
    stereo::StereoOptions o =
        m == Method::kHdr ? options.hdr_stereo : options.ldr_stereo;
    o.max_disparity = max_disparity;
    // One thread a matching: the matchings themselves run in parallel.
    o.threads = 1;
    const StereoPair& pair = pairs.at(m);
    absl::StatusOr<stereo::StereoResult> r =
        stereo::ComputeDisparity(pair.left, pair.right, o);
    if (!r.ok()) {
      return absl::Status(
          r.status().code(),
          absl::StrCat("stereo ", MethodName(m), ": ", r.status().message()));
    }
    out[static_cast<size_t>(i)] = {r->disparity, r->consistent};
    return absl::OkStatus();
  }));
  std::map<Method, Candidate> result;
  for (size_t i = 0; i < methods.size(); ++i) {
    result[methods[i]] = std::move(out[i]);
  }
  return result;
}

absl::StatusOr<fusion::FusionResult> FuseSome(
    const std::vector<const Candidate*>& candidates, const FusionViews& views,
    int max_disparity, const ExperimentOptions& options) {
  std::vector<cv::Mat> disparities, confidences;
  if (options.robust_fusion.enabled) {
    std::vector<cv::Mat> consistent;
    for (const Candidate* c : candidates) {
      disparities.push_back(c->disparity);
      consistent.push_back(c->consistent);
    }
    return fusion::FuseByReliability(
        disparities, consistent, views.guide, views.left, views.right,
        FusionOf(options, max_disparity), options.robust_fusion);
  }
  for (const Candidate* c : candidates) {
    disparities.push_back(c->disparity);
    // Confidences of 1 everywhere are the same as none (and slower).
    if (options.inconsistent_confidence < 1) {
      confidences.push_back(ConfidenceOf(*c, options.inconsistent_confidence));
    }
  }
  return fusion::FuseAlphaExpansion(
      disparities, views.guide, FusionOf(options, max_disparity), confidences);
}

absl::StatusOr<Fused> FuseMethods(const std::map<Method, Candidate>& candidates,
                                  const FusionViews& views, int max_disparity,
                                  const ExperimentOptions& options,
                                  const UnitRunner& runner) {
  std::vector<const Candidate*> seven;
  std::vector<cv::Mat> disparities;
  for (Method m : ToneMappedMethods()) {
    auto it = candidates.find(m);
    if (it == candidates.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat("fusion: the ", MethodName(m), " candidate is missing"));
    }
    seven.push_back(&it->second);
    disparities.push_back(it->second.disparity);
  }
  const std::vector<Method>& methods = FusedMethods();
  std::vector<cv::Mat> out(methods.size());
  fusion::SolverStats stats;
  fusion::RefinementCounts refinement;
  RETURN_IF_ERROR(runner(NamesOf(methods), [&](int i) -> absl::Status {
    cv::Mat& d = out[static_cast<size_t>(i)];
    const Method m = methods[static_cast<size_t>(i)];
    if (m == Method::kMean) {
      ASSIGN_OR_RETURN(d, fusion::FuseMean(disparities, max_disparity));
    } else if (m == Method::kMedian) {
      ASSIGN_OR_RETURN(d, fusion::FuseMedian(disparities, max_disparity));
    } else {
      ASSIGN_OR_RETURN(const fusion::FusionResult r,
                       FuseSome(seven, views, max_disparity, options));
      d = r.disparity;
      stats = r.stats;
      refinement = r.refinement;
    }
    return absl::OkStatus();
  }));
  Fused fused;
  for (size_t i = 0; i < methods.size(); ++i) {
    fused.disparity[methods[i]] = std::move(out[i]);
  }
  fused.stats = stats;
  fused.refinement = refinement;
  return fused;
}

absl::StatusOr<eval::RegionMetrics> Score(const cv::Mat& disparity,
                                          const cv::Mat& truth,
                                          const cv::Mat& nonoccluded,
                                          const ExperimentOptions& options) {
  ASSIGN_OR_RETURN(const eval::DisparityEvaluation e,
                   eval::EvaluateDisparity(disparity, truth, nonoccluded,
                                           cv::Mat(), options.evaluation));
  return e.nonoccluded;
}

}  // namespace hdrstereo::experiment
