// SPDX-License-Identifier: GPL-3.0-or-later
//
// Disparity maps scored against ground truth (thesis Tables 5.2/5.3:
// RMSE; Middlebury: bad-pixel rates), and colour-mapped visualisations.
//
// Ground truth is valid where finite (and > 0 unless gt_zero_valid: a 0 in
// Middlebury PNG/PFM truth means "unknown"). An estimate is valid where
// finite. Regions, each intersected with the optional user mask:
//   all          every pixel with valid truth;
//   nonoccluded  valid truth and the non-occlusion mask (= all without one);
//   valid        valid truth and a valid estimate.
// In `all` and `nonoccluded` a missing estimate counts as bad at every
// threshold and is left out of RMSE/MAE (`coverage` says how many had one).
#ifndef HDRSTEREO_PROCESSING_EVAL_DISPARITY_EVAL_H_
#define HDRSTEREO_PROCESSING_EVAL_DISPARITY_EVAL_H_

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::eval {

struct EvalOptions {
  std::vector<double> thresholds = {0.5, 1.0, 2.0, 4.0};  // px, error > t
  bool gt_zero_valid = false;
  // The estimate is multiplied by this before comparison (e.g. to undo a
  // Middlebury disparity scale); truth is used as is.
  double disparity_scale = 1.0;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const EvalOptions& o);

struct RegionMetrics {
  int64_t pixels = 0;     // pixels in the region
  int64_t estimated = 0;  // of which the estimate is valid
  double coverage = 0;    // estimated / pixels
  double rmse = 0;        // over estimated pixels
  double mae = 0;
  std::vector<double> bad_percent;  // per threshold, percent of `pixels`
};

struct DisparityEvaluation {
  std::vector<double> thresholds;
  RegionMetrics all, nonoccluded, valid;
};

// disparity, truth: CV_32FC1 of one size. nonoccluded, mask: optional
// CV_8UC1 of the same size (non-zero = inside).
absl::StatusOr<DisparityEvaluation> EvaluateDisparity(
    const cv::Mat& disparity, const cv::Mat& truth,
    const cv::Mat& nonoccluded = cv::Mat(), const cv::Mat& mask = cv::Mat(),
    const EvalOptions& options = {});

// JSON object {"thresholds": [...], "all": {...}, "nonoccluded": {...},
// "valid": {...}}, each region with pixels, estimated, coverage, rmse, mae,
// bad (object "0.5": percent, ...; keys are the thresholds in %g), keys
// sorted, indented by 2. Built with nlohmann-json: a NaN or infinite number
// (an RMSE whose sum of squares overflowed) is written as null, which its
// readers (people and scripts reading `hdrstereo-proc eval --json`) must
// take as "not a number".
std::string EvaluationToJson(const DisparityEvaluation& evaluation);
// A short human-readable table.
std::string EvaluationToText(const DisparityEvaluation& evaluation);

// Colour maps (CV_8UC3 BGR). Disparity: viridis over [min_disp, max_disp]
// (perceptually uniform; pass min >= max to use the map's finite range).
// Error: |disparity - truth| clamped to [0, max_error] with OpenCV's
// perceptually uniform "plasma" map. Invalid pixels (non-finite estimate or
// truth) are black in both; neither map contains black.
absl::StatusOr<cv::Mat> ColorizeDisparity(const cv::Mat& disparity,
                                          double min_disp = 0,
                                          double max_disp = 0);
absl::StatusOr<cv::Mat> ColorizeError(const cv::Mat& disparity,
                                      const cv::Mat& truth,
                                      double max_error = 4.0,
                                      const EvalOptions& options = {});

}  // namespace hdrstereo::eval

#endif  // HDRSTEREO_PROCESSING_EVAL_DISPARITY_EVAL_H_
