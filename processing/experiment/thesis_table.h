// SPDX-License-Identifier: GPL-3.0-or-later
//
// The thesis' Tables 5.2 and 5.3 for one HDR stereo data set: from the left
// and right exposure stacks, merge HDR (Debevec & Malik, response recovered
// from the left stack), tone-map the pair with all seven operators (shared
// normalisation), match the LDR middle exposure, each tone-mapped pair and
// the HDR radiance (HDR-CVF, Eq. 4.2) with the cost-volume filtering
// matcher, then fuse the seven tone-mapped disparities:
//   mean, median        per-pixel baselines (Table 5.3);
//   fused-4             graph-cut fusion of 4 of the 7, averaged over all 35
//                       subsets (the thesis: "4 random" maps);
//   fused-7             graph-cut fusion of all seven (Table 5.2/5.3).
// Each row is scored against the truth (RMSE and bad-1px, percent of
// pixels with |error| > 1) on the non-occluded pixels.
#ifndef HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_TABLE_H_
#define HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_TABLE_H_

#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "processing/fusion/fusion.h"
#include "processing/hdr/stack.h"

namespace hdrstereo::fusion {

struct TableInput {
  std::string name;
  hdr::ExposureStack left, right;  // same exposure times, same order
  int ldr_index = -1;              // LDR row's exposure; -1 = the middle
  cv::Mat truth;                   // CV_32FC1 left disparity (inf = none)
  cv::Mat nonoccluded;             // CV_8UC1, optional
  int max_disp = 0;                // 0 = from the truth (max + 2)
};

struct TableOptions {
  FusionParams fusion;  // max_disp is set from the input
  // Candidates' left-right check: pixels that fail it get this confidence
  // in the data term (1 = ignore the check). Default 1: on the simulated
  // scenes down-weighting inconsistent pixels made fusion worse (lab-lamp,
  // 256 px: fused-7 RMSE 0.71 at 1, 1.72 at 0.25, 2.84 at 0.05) -- the
  // failing TMOs' errors are often left-right consistent.
  double inconsistent_confidence = 1.0;
  bool fused4_all_subsets = true;  // else the first 4 only
};

struct TableRow {
  std::string name;
  double rmse = 0;
  double bad1 = 0;  // percent of scored pixels
};

struct TableResult {
  std::string name;
  std::vector<TableRow> rows;  // LDR, the 7 TMOs, HDR-CVF, mean, median,
                               // fused-4, fused-7
  std::map<std::string, cv::Mat> disparity;  // by row name (fused-4: none)
  SolverStats fused7_stats;
};

absl::StatusOr<TableResult> RunThesisTable(const TableInput& input,
                                           const TableOptions& options = {});

// Markdown: one RMSE and one bad-1px column per data set plus their means,
// the rows in TableResult order.
std::string FormatTable(const std::vector<TableResult>& results);

// Mean over the data sets of row `name` (RMSE or bad-1px); -1 if missing.
double MeanRmse(const std::vector<TableResult>& results,
                const std::string& name);
double MeanBad1(const std::vector<TableResult>& results,
                const std::string& name);

}  // namespace hdrstereo::fusion

#endif  // HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_TABLE_H_
