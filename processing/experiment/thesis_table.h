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
  bool details = false;            // fill TableResult::details
};

struct TableRow {
  Method method = Method::kLdr;
  double rmse = 0;
  double bad1 = 0;  // percent of scored pixels
};

// One approach's errors in detail (the resolution study, docs/results.md),
// on the non-occluded pixels. `scaled` is bad-(width / kReferenceWidth)
// px: the bad-1px threshold scaled with the image, so that a method whose
// errors grow in proportion to the image keeps its rate. Regions of the LDR
// left view, each pixel in the first that applies: left band (the first
// max-disparity columns, no match in the right view), saturated (grey >=
// 250), dark (<= 10), low texture (mean Sobel magnitude over 9 x 9 < 20 on
// the view resized to kReferenceWidth when wider, so that a surface is in
// the same region at every size), textured.
inline constexpr int kReferenceWidth = 320;  // the thesis table's width
struct RegionScore {
  std::string region;
  double share = 0;  // percent of the scored pixels
  double rmse = 0;
  double bad1 = 0;  // percent of the region's pixels
};
struct DetailRow {
  std::string approach;  // a method's name, or "oracle": per pixel the
                         // candidate of the seven closest to the truth
  double rmse = 0;
  double bad1 = 0;
  double bad2 = 0;
  double scaled = 0;
  std::vector<RegionScore> regions;
};

struct TableResult {
  std::string name;
  int width = 0;                        // of the images
  std::vector<DetailRow> details;       // TableOptions::details
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

// Markdown: per data set, the details' rows (RMSE, bad-1/2px, scaled, and
// per region RMSE / bad-1px with the region's share in the header).
std::string FormatDetails(const std::vector<TableResult>& results);

// Mean over the data sets of a method's RMSE or bad-1px; -1 if missing.
double MeanRmse(const std::vector<TableResult>& results, Method method);
double MeanBad1(const std::vector<TableResult>& results, Method method);

}  // namespace hdrstereo::experiment

#endif  // HDRSTEREO_PROCESSING_EXPERIMENT_THESIS_TABLE_H_
