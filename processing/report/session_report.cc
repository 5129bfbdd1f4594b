// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/report/session_report.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/io/capture_layout.h"
#include "processing/io/image.h"

namespace hdrstereo::report {
namespace {

// Adds the figures of a section and the files they show.
class Figures {
 public:
  explicit Figures(SessionReport& report) : report_(report) {}
  void Image(Section& section, const std::string& name, const cv::Mat& image,
             const std::string& caption) {
    report_.files.push_back({name, FigureOf(io::To8Bit(image)), ""});
    section.figures.push_back({name, caption});
  }
  void Copy(Section& section, const std::string& name, const std::string& from,
            const std::string& caption) {
    report_.files.push_back({name, cv::Mat(), from});
    section.figures.push_back({name, caption});
  }

 private:
  SessionReport& report_;
};

}  // namespace

cv::Mat FigureOf(const cv::Mat& image) {
  if (image.cols <= kMaxFigureWidth) return image;
  const int height =
      std::max(1, static_cast<int>(std::lround(static_cast<double>(image.rows) *
                                               kMaxFigureWidth / image.cols)));
  cv::Mat out;
  cv::resize(image, out, cv::Size(kMaxFigureWidth, height), 0, 0,
             cv::INTER_AREA);
  return out;
}

absl::StatusOr<SessionReport> BuildSessionReport(const SessionReportInput& in) {
  SessionReport report;
  Page& page = report.page;
  Figures figures(report);
  page.title = in.title;
  page.summary = in.summary;

  Section exposures{"Exposure stack", "Rectified, longest first.", {}, {}};
  for (int v = 0; v < 2; ++v) {
    const std::string view = io::ViewName(v);
    for (size_t i = 0; i < in.exposures[v].size(); ++i) {
      figures.Image(exposures, absl::StrCat("exposure_", view, "_", i, ".png"),
                    in.exposures[v][i],
                    absl::StrCat(view, " ", in.exposure_tags[i]));
    }
  }
  page.sections.push_back(std::move(exposures));

  Section preview{
      "HDR preview", "Left HDR radiance tone-mapped with Reinhard.", {}, {}};
  figures.Copy(preview, "hdr_preview.png", in.hdr_preview, "HDR (reinhard)");
  page.sections.push_back(std::move(preview));

  Section tmo{"Tone-mapped pairs", "", {}, {}};
  for (const auto& [op, files] : in.tonemapped) {
    for (int v = 0; v < 2; ++v) {
      figures.Copy(tmo, absl::StrCat("tonemapped_", op, "_im", v, ".png"),
                   files[v], absl::StrCat(op, " ", io::ViewName(v)));
    }
  }
  page.sections.push_back(std::move(tmo));

  Section gt{"Ground truth", "", {}, {}};
  if (in.truths.empty()) gt.text = "No ground truth for this session.";
  for (const SessionReportInput::Truth& t : in.truths) {
    ASSIGN_OR_RETURN(const cv::Mat colour,
                     eval::ColorizeDisparity(t.disparity, 0, in.max_disparity));
    figures.Image(gt, absl::StrCat("gt_", t.name, ".png"), colour,
                  absl::StrCat(t.name, " disparity"));
    figures.Image(gt, absl::StrCat("gt_", t.name, "_invalid.png"),
                  t.mask0nocc == 0, absl::StrCat(t.name, " invalid (white)"));
  }
  page.sections.push_back(std::move(gt));

  Section disp{"Disparity", "Viridis over the disparity range.", {}, {}};
  Section err{"Error",
              "|disparity - truth|, plasma over 0..4 px, black where unknown.",
              {},
              {}};
  for (const auto& [method, d] : in.disparities) {
    ASSIGN_OR_RETURN(const cv::Mat colour,
                     eval::ColorizeDisparity(d, 0, in.max_disparity));
    figures.Image(disp, absl::StrCat("disp_", method, ".png"), colour, method);
    for (const SessionReportInput::Truth& t : in.truths) {
      ASSIGN_OR_RETURN(const cv::Mat e, eval::ColorizeError(d, t.disparity, 4.0,
                                                            in.error_options));
      figures.Image(err, absl::StrCat("error_", t.name, "_", method, ".png"), e,
                    absl::StrCat(method, " vs ", t.name));
    }
  }
  page.sections.push_back(std::move(disp));
  if (!in.truths.empty()) page.sections.push_back(std::move(err));

  Section table{"Metrics",
                "Non-occluded pixels; bad-t = percent of scored pixels with "
                "error > t px (or no estimate); sorted by RMSE.",
                {},
                {}};
  if (in.metrics.rows.empty()) table.text = "No metrics: no ground truth.";
  table.tables.push_back(in.metrics);
  page.sections.push_back(std::move(table));
  return report;
}

}  // namespace hdrstereo::report
