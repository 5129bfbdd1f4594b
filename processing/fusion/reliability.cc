// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/reliability.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::fusion {
namespace {

// The candidates as every fusion checks them; the masks, when given, one
// CV_8UC1 of their size (or empty) per candidate.
absl::Status CheckInputs(const std::vector<cv::Mat>& candidates,
                         const std::vector<cv::Mat>& consistent) {
  RETURN_IF_ERROR(CheckCandidateMaps(candidates));
  const cv::Size size = candidates[0].size();
  if (consistent.empty()) return absl::OkStatus();
  if (consistent.size() != candidates.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("fusion: ", consistent.size(), " left-right masks for ",
                     candidates.size(), " candidates"));
  }
  for (size_t k = 0; k < consistent.size(); ++k) {
    const cv::Mat& lr = consistent[k];
    if (!lr.empty() && (lr.type() != CV_8UC1 || lr.size() != size)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "fusion: left-right mask ", k, " must be CV_8UC1 of that size"));
    }
  }
  return absl::OkStatus();
}

// Where candidate k passed its left-right check (when masks are given) and
// lies within tau of the estimate. NaN differences compare false: no
// agreement where either is invalid.
cv::Mat Agrees(const std::vector<cv::Mat>& candidates,
               const std::vector<cv::Mat>& consistent, size_t k,
               const cv::Mat& estimate, double tau) {
  cv::Mat agree = cv::abs(candidates[k] - estimate) <= tau;
  if (!consistent.empty() && !consistent[k].empty()) {
    agree &= consistent[k] != 0;
  }
  return agree;
}

// The agreement tolerance (and the data term's sigma) at this width.
double Tau(const ReliabilityOptions& options, int width) {
  return options.sigma_fraction * width;
}

}  // namespace

absl::Status ReliabilityOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(sigma_fraction > 0 && sigma_fraction <= 0.1,
                               "sigma_fraction", sigma_fraction,
                               "in (0, 0.1]"));
  RETURN_IF_ERROR(RequireField(window_fraction > 0 && window_fraction <= 2,
                               "window_fraction", window_fraction,
                               "in (0, 2]"));
  RETURN_IF_ERROR(RequireField(exponent >= 0 && exponent <= 16, "exponent",
                               exponent, "in [0, 16]"));
  RETURN_IF_ERROR(RequireField(passes >= 1 && passes <= 10, "passes", passes,
                               "in [1, 10]"));
  RETURN_IF_ERROR(WithFieldPrefix("planes", planes.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("photo", photo.Validate()));
  return WithFieldPrefix("speckles", speckles.Validate());
}

void to_json(nlohmann::json& j, const ReliabilityOptions& o) {
  const auto& [enabled, sigma_fraction, window_fraction, exponent, passes,
               planes, photo, speckles] = o;
  j = nlohmann::json{{"enabled", enabled},
                     {"sigma_fraction", sigma_fraction},
                     {"window_fraction", window_fraction},
                     {"exponent", exponent},
                     {"passes", passes},
                     {"planes", planes},
                     {"photo", photo},
                     {"speckles", speckles}};
}

absl::StatusOr<std::vector<cv::Mat>> CandidateConfidences(
    const std::vector<cv::Mat>& candidates,
    const std::vector<cv::Mat>& consistent, const cv::Mat& estimate,
    const ReliabilityOptions& options) {
  RETURN_IF_ERROR(options.Validate());
  RETURN_IF_ERROR(CheckInputs(candidates, consistent));
  const cv::Size size = candidates[0].size();
  if (estimate.type() != CV_32FC1 || estimate.size() != size) {
    return absl::InvalidArgumentError(
        "fusion: the estimate must be CV_32FC1 of the candidates' size");
  }
  const double tau = Tau(options, size.width);
  const int window =
      std::max(1, static_cast<int>(options.window_fraction * size.width)) | 1;
  std::vector<cv::Mat> out;
  for (size_t k = 0; k < candidates.size(); ++k) {
    cv::Mat rate;
    Agrees(candidates, consistent, k, estimate, tau)
        .convertTo(rate, CV_32F, 1.0 / 255.0);
    cv::boxFilter(rate, rate, -1, cv::Size(window, window), cv::Point(-1, -1),
                  true, cv::BORDER_REFLECT);
    cv::pow(rate, options.exponent, rate);
    out.push_back(rate);
  }
  cv::Mat best = out[0].clone();
  for (const cv::Mat& r : out) best = cv::max(best, r);
  const cv::Mat unsupported = best <= 0;
  best.setTo(1.0f, unsupported);
  for (cv::Mat& r : out) {
    cv::divide(r, best, r);
    r.setTo(1.0f, unsupported);
  }
  return out;
}

absl::StatusOr<cv::Mat> ConsistentMedian(const std::vector<cv::Mat>& candidates,
                                         const std::vector<cv::Mat>& consistent,
                                         int max_disp) {
  RETURN_IF_ERROR(CheckInputs(candidates, consistent));
  ASSIGN_OR_RETURN(cv::Mat all, FuseMedian(candidates, max_disp));
  if (consistent.empty()) return all;
  // The median with each candidate's failing pixels made invalid (NaN).
  std::vector<cv::Mat> passed;
  for (size_t k = 0; k < candidates.size(); ++k) {
    cv::Mat z = candidates[k].clone();
    if (!consistent[k].empty()) {
      z.setTo(std::numeric_limits<float>::quiet_NaN(), consistent[k] == 0);
    }
    passed.push_back(z);
  }
  ASSIGN_OR_RETURN(cv::Mat median, FuseMedian(passed, max_disp));
  // NaN where no candidate passed. (Not `median != median`: OpenCV's
  // vectorised != is false for NaN.)
  const cv::Mat none = ~(median == median);
  all.copyTo(median, none);
  return median;
}

absl::StatusOr<cv::Mat> ReliablePixels(const std::vector<cv::Mat>& candidates,
                                       const std::vector<cv::Mat>& consistent,
                                       const cv::Mat& fused, double tau) {
  RETURN_IF_ERROR(CheckInputs(candidates, consistent));
  if (fused.type() != CV_32FC1 || fused.size() != candidates[0].size()) {
    return absl::InvalidArgumentError(
        "fusion: the fused map must be CV_32FC1 of the candidates' size");
  }
  cv::Mat count = cv::Mat::zeros(fused.size(), CV_8UC1);
  for (size_t k = 0; k < candidates.size(); ++k) {
    cv::add(count, 1, count, Agrees(candidates, consistent, k, fused, tau));
  }
  return cv::Mat(count >= 2);
}

absl::StatusOr<FusionResult> FuseByReliability(
    const std::vector<cv::Mat>& candidates,
    const std::vector<cv::Mat>& consistent, const cv::Mat& guide,
    const cv::Mat& left, const cv::Mat& right, FusionOptions params,
    const ReliabilityOptions& options) {
  RETURN_IF_ERROR(options.Validate());
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(cv::Mat estimate,
                   ConsistentMedian(candidates, consistent, params.max_disp));
  params.sigma = Tau(options, estimate.cols);
  FusionResult result;
  for (int pass = 0; pass < options.passes; ++pass) {
    ASSIGN_OR_RETURN(
        const std::vector<cv::Mat> confidences,
        CandidateConfidences(candidates, consistent, estimate, options));
    ASSIGN_OR_RETURN(
        result, FuseAlphaExpansion(candidates, guide, params, confidences));
    estimate = result.disparity;
  }
  const double tau = Tau(options, estimate.cols);
  RefinementCounts& refinement = result.refinement;  // zero from the cuts
  if (options.planes.enabled) {
    ASSIGN_OR_RETURN(const cv::Mat reliable,
                     ReliablePixels(candidates, consistent, estimate, tau));
    ASSIGN_OR_RETURN(PlanePriorResult planes,
                     ApplyPlanePrior(estimate, reliable, left, tau,
                                     params.max_disp, options.planes));
    estimate = std::move(planes.disparity);
    refinement.segments = planes.segments;
    refinement.planes = planes.planes;
    refinement.plane_fraction = planes.replaced_fraction;
  }
  if (options.photo.enabled) {
    ASSIGN_OR_RETURN(
        PhotoConsistencyResult photo,
        ChooseByPhotoConsistency(estimate, candidates, left, right, tau,
                                 params.max_disp, options.photo));
    estimate = std::move(photo.disparity);
    refinement.photo_fraction = photo.replaced_fraction;
  }
  if (options.speckles.enabled) {
    ASSIGN_OR_RETURN(
        SpeckleResult speckles,
        RemoveSpeckles(estimate, tau, params.max_disp, options.speckles));
    estimate = std::move(speckles.disparity);
    refinement.speckle_fraction = speckles.replaced_fraction;
  }
  result.disparity = estimate;
  result.stats.total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return result;
}

}  // namespace hdrstereo::fusion
