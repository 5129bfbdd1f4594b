// SPDX-License-Identifier: GPL-3.0-or-later
//
// A processed session's HTML report (the pipeline's report step): the
// capture summary, the exposure stack, an HDR preview, the tone-mapped
// pairs, the ground truths, every method's disparity and error maps, and
// the metrics table. BuildSessionReport lays the page out and says which
// files go beside it; the caller writes them (and the page) atomically.
#ifndef HDRSTEREO_PROCESSING_REPORT_SESSION_REPORT_H_
#define HDRSTEREO_PROCESSING_REPORT_SESSION_REPORT_H_

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "processing/eval/disparity_eval.h"
#include "processing/report/html_report.h"

namespace hdrstereo::report {

struct SessionReportInput {
  std::string title;
  std::vector<std::pair<std::string, std::string>> summary;  // in order
  std::vector<std::string> exposure_tags;  // of the stacks, longest first
  std::array<std::vector<cv::Mat>, 2> exposures;  // left, right stacks
  // Files the page shows as they are (paths the caller resolves): the HDR
  // preview and each operator's tone-mapped pair.
  std::string hdr_preview;
  std::vector<std::pair<std::string, std::array<std::string, 2>>> tonemapped;
  struct Truth {
    std::string name;
    cv::Mat disparity;  // CV_32FC1, +inf unknown
    cv::Mat mask0nocc;  // Middlebury mask; 0 = unknown
  };
  std::vector<Truth> truths;
  // Each method's disparity (CV_32FC1), in the page's order.
  std::vector<std::pair<std::string, cv::Mat>> disparities;
  int max_disparity = 0;            // the colour map's range, 0 .. this
  eval::EvalOptions error_options;  // which truth pixels the error maps use
  Table metrics;                    // rows in order; none = no ground truth
};

// Figures wider than this are shown shrunk to it: the page of a
// 24-megapixel session would otherwise weigh most of a gigabyte. The
// full-size files stay where the pipeline wrote them.
inline constexpr int kMaxFigureWidth = 1600;
// `image` as the page shows it: itself, or shrunk to kMaxFigureWidth
// (area average, aspect ratio kept).
cv::Mat FigureOf(const cv::Mat& image);

// One file beside the page: an 8-bit image written as PNG, or a copy of
// `copy_from` (an image the caller passes through FigureOf when it is
// wider than kMaxFigureWidth).
struct ReportFile {
  std::string name;
  cv::Mat image;
  std::string copy_from;
};

struct SessionReport {
  Page page;
  std::vector<ReportFile> files;  // in the order the page shows them
};

// INVALID_ARGUMENT when a disparity or truth cannot be colour-mapped.
absl::StatusOr<SessionReport> BuildSessionReport(
    const SessionReportInput& input);

}  // namespace hdrstereo::report

#endif  // HDRSTEREO_PROCESSING_REPORT_SESSION_REPORT_H_
