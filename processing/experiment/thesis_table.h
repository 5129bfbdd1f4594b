// SPDX-License-Identifier: GPL-3.0-or-later
//
// The thesis' Tables 5.2 and 5.3 for one HDR stereo data set: the thesis
// experiment (thesis_experiment.h) on the left and right exposure stacks in
// memory, every method scored against the truth (RMSE and bad-1px, percent
// of pixels with |error| > 1) on the non-occluded pixels. Besides what a
// processed session has, the table has fused-4: graph-cut fusion of 4 of
// the 7 tone-mapped disparities, averaged over all 35 subsets (the thesis:
// "4 random" maps).
#ifndef HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_TABLE_H_
#define HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_TABLE_H_

#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "processing/experiment/method.h"
#include "processing/experiment/thesis_experiment.h"
#include "processing/fusion/fusion.h"
#include "processing/hdr/stack.h"

namespace hdrstereo::experiment {

struct TableInput {
  std::string name;
  hdr::ExposureStack left, right;  // same exposure times, same order
  int ldr_index = -1;              // LDR row's exposure; -1 = the middle
  cv::Mat truth;                   // CV_32FC1 left disparity (inf = none)
  cv::Mat nonoccluded;             // CV_8UC1, optional
  int max_disp = 0;                // 0 = DisparityRange of the truth
};

struct TableOptions {
  ExperimentOptions experiment;
  bool fused4_all_subsets = true;  // else the first 4 only
  int threads = 2;                 // matchings and fusions in parallel
};

struct TableRow {
  Method method = Method::kLdr;
  double rmse = 0;
  double bad1 = 0;  // percent of scored pixels
};

struct TableResult {
  std::string name;
  std::vector<TableRow> rows;           // ldr, the 7 TMOs, hdr, mean, median,
                                        // fused-4, fused
  std::map<Method, cv::Mat> disparity;  // by method (fused-4: none)
  fusion::SolverStats fused_stats;
};

absl::StatusOr<TableResult> RunThesisTable(const TableInput& input,
                                           const TableOptions& options = {});

// Markdown: one RMSE and one bad-1px column per data set plus their means,
// the rows in TableResult order.
std::string FormatTable(const std::vector<TableResult>& results);

// Mean over the data sets of a method's RMSE or bad-1px; -1 if missing.
double MeanRmse(const std::vector<TableResult>& results, Method method);
double MeanBad1(const std::vector<TableResult>& results, Method method);

}  // namespace hdrstereo::experiment

#endif  // HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_TABLE_H_
