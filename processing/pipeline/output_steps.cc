// SPDX-License-Identifier: GPL-3.0-or-later
//
// evaluate: every method scored against every ground truth
// (metrics/metrics.json and RunStore::RecordMetrics). export: the
// Middlebury 2014 files of the session. report: the HTML page
// (processing/report/session_report.h) in report/.
#include <algorithm>
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/eval/disparity_eval.h"
#include "processing/experiment/method.h"
#include "processing/experiment/thesis_experiment.h"
#include "processing/io/capture_layout.h"
#include "processing/io/image.h"
#include "processing/io/middlebury.h"
#include "processing/io/sha256.h"
#include "processing/pipeline/session_files.h"
#include "processing/pipeline/steps.h"
#include "processing/report/html_report.h"
#include "processing/report/session_report.h"

namespace hdrstereo::pipeline {
namespace {

using experiment::Method;

std::string DisparityFile(Method m) {
  return absl::StrCat("disparity/", experiment::MethodName(m), ".pfm");
}

// One metrics row from a score of `method` against the truth `truth`.
Metric MetricRow(std::string method, std::string truth,
                 const eval::RegionMetrics& r) {
  Metric row;
  row.method = std::move(method);
  row.ground_truth = std::move(truth);
  row.rmse = r.rmse;
  row.mae = r.mae;
  row.bad_0_5 = r.bad_percent.at(0);
  row.bad_1 = r.bad_percent.at(1);
  row.bad_2 = r.bad_percent.at(2);
  row.bad_4 = r.bad_percent.at(3);
  row.coverage = 100.0 * r.coverage;
  return row;
}

// With both the structured-light ground truth and the simulator's exact
// truth, the first scored against the second (its accuracy, and its
// coverage of the non-occluded pixels), as the row kGroundTruthMethod. A
// truth that cannot be scored (e.g. of another size) is a warning: the
// methods' rows do not depend on it.
void ScoreGroundTruth(const std::vector<Truth>& truths,
                      const experiment::ExperimentOptions& options,
                      StepContext& c, std::vector<Metric>* rows) {
  const Truth* sl = nullptr;
  const Truth* exact = nullptr;
  for (const Truth& t : truths) {
    if (t.name == "structured_light") sl = &t;
    if (t.name == "simulation") exact = &t;
  }
  if (sl == nullptr || exact == nullptr) return;
  // Both truths are in pixels: the scale meant for a method's output does
  // not apply.
  experiment::ExperimentOptions truth_options = options;
  truth_options.evaluation.disparity_scale = 1.0;
  absl::StatusOr<eval::RegionMetrics> score = experiment::Score(
      sl->disparity, exact->disparity, exact->nonoccluded, truth_options);
  if (!score.ok()) {
    c.Warn(absl::StrCat(
        "evaluate: the structured-light ground truth cannot be scored against "
        "the simulation: ",
        score.status().message()));
    return;
  }
  rows->push_back(MetricRow(kGroundTruthMethod, exact->name, *score));
}

absl::Status RunEvaluate(const experiment::ExperimentOptions& options,
                         StepContext& c) {
  ASSIGN_OR_RETURN(const std::vector<Truth> truths, c.Truths());
  std::vector<Metric> rows;
  if (truths.empty()) {
    c.Warn(
        "evaluate: no ground truth (no structured-light capture, no "
        "simulator truth): no metrics");
  }
  for (const Truth& t : truths) {
    for (Method m : experiment::SessionMethods()) {
      ASSIGN_OR_RETURN(const cv::Mat d, c.ReadPfm(DisparityFile(m)));
      absl::StatusOr<eval::RegionMetrics> score =
          experiment::Score(d, t.disparity, t.nonoccluded, options);
      if (!score.ok()) {
        return absl::Status(
            score.status().code(),
            absl::StrCat("evaluate ", experiment::MethodName(m), " against ",
                         t.name, ": ", score.status().message()));
      }
      rows.push_back(MetricRow(experiment::MethodName(m), t.name, *score));
    }
  }
  ScoreGroundTruth(truths, options, c, &rows);
  RETURN_IF_ERROR(
      c.outputs().WriteText("metrics", kMetricsFile, MetricsToJson(rows)));
  return c.state().RecordMetrics(rows);
}

absl::Status RunExport(StepContext& c) {
  ASSIGN_OR_RETURN(const hdr::StackImage left, c.Ldr(0));
  ASSIGN_OR_RETURN(const hdr::StackImage right, c.Ldr(1));
  RETURN_IF_ERROR(c.outputs().WriteImage("export", "im0.png", left.image));
  RETURN_IF_ERROR(c.outputs().WriteImage("export", "im1.png", right.image));
  const cv::Size size = left.image.size();
  ASSIGN_OR_RETURN(const std::vector<Truth> truths, c.Truths());
  if (truths.empty()) {
    c.Warn(absl::StrCat("export: no ground truth: no ", io::kDisparity0File,
                        " / ", io::kMask0File));
  } else {
    const Truth& t = truths.front();
    RETURN_IF_ERROR(io::WriteGroundTruth(c.dir(), t.disparity, t.mask0nocc));
    for (const char* name : {io::kDisparity0File, io::kMask0File}) {
      c.outputs().Record("export", name);
    }
  }
  io::Calib calib;
  if (c.input().intrinsics) {
    calib.fx = c.input().intrinsics->fx;
    calib.fy = c.input().intrinsics->fy;
    calib.cx = c.input().intrinsics->cx;
    calib.cy = c.input().intrinsics->cy;
  } else {
    // A nominal camera (horizontal field of view about 53 degrees) keeps
    // calib.txt parseable; depth from it is only indicative.
    calib.fx = calib.fy = size.width;
    calib.cx = (size.width - 1) / 2.0;
    calib.cy = (size.height - 1) / 2.0;
    c.Warn(
        "export: camera intrinsics unknown: calib.txt has a nominal focal "
        "length (image width)");
  }
  ASSIGN_OR_RETURN(const int max_disp, c.MaxDisparity(size.width));
  calib.baseline_mm = c.input().baseline_mm;
  calib.width = size.width;
  calib.height = size.height;
  calib.ndisp = max_disp + 1;
  return c.outputs().Write("export", io::kCalibFile,
                           [&](const std::filesystem::path& path) {
                             return io::WriteCalib(path, calib);
                           });
}

report::Table MetricsTable(const std::vector<Metric>& metrics) {
  report::Table t{"metrics",
                  {"ground truth", "method", "RMSE", "MAE", "bad-0.5 %",
                   "bad-1 %", "bad-2 %", "bad-4 %", "coverage %", "vs LDR"},
                  {}};
  const std::vector<Metric> sorted = SortMetrics(metrics);
  const std::vector<bool> worse = WorseThanLdr(sorted);
  for (size_t i = 0; i < sorted.size(); ++i) {
    const Metric& m = sorted[i];
    t.rows.push_back(
        {m.ground_truth, m.method, absl::StrFormat("%.3f", m.rmse),
         absl::StrFormat("%.3f", m.mae), absl::StrFormat("%.1f", m.bad_0_5),
         absl::StrFormat("%.1f", m.bad_1), absl::StrFormat("%.1f", m.bad_2),
         absl::StrFormat("%.1f", m.bad_4), absl::StrFormat("%.1f", m.coverage),
         worse[i] ? "worse than LDR" : ""});
  }
  return t;
}

absl::Status RunReport(const eval::EvalOptions& error_options,
                       int matching_width, StepContext& c) {
  const SessionInput& in = c.input();
  report::SessionReportInput r;
  r.title = absl::StrCat("Session ", in.session_name);
  r.summary = in.capture_summary;
  for (int v = 0; v < 2; ++v) {
    ASSIGN_OR_RETURN(const hdr::ExposureStack stack, c.Stack(v));
    r.exposures[v] = stack.images;
    if (v == 0) {
      for (double e : stack.exposure_s) {
        r.exposure_tags.push_back(io::ExposureTag(e));
      }
    }
  }
  const cv::Size size = r.exposures[0][0].size();
  ASSIGN_OR_RETURN(r.max_disparity, c.MaxDisparity(size.width));
  const FrameSelection& frames = c.frames();
  r.summary.push_back({"exposures", absl::StrJoin(r.exposure_tags, ", ")});
  r.summary.push_back({"baseline", absl::StrFormat("%.1f mm", in.baseline_mm)});
  r.summary.push_back(
      {"frames", absl::StrCat(in.frames.size(), " (",
                              frames.stereo[0].size() + frames.stereo[1].size(),
                              " stereo, ", frames.structured_light.size(),
                              " structured light)")});
  r.summary.push_back(
      {"image size",
       absl::StrCat(size.width, " x ", size.height,
                    size.width > report::kMaxFigureWidth
                        ? absl::StrCat(" (figures shown ",
                                       report::kMaxFigureWidth, " px wide)")
                        : "")});
  r.summary.push_back(
      {"disparity range", absl::StrCat("0 .. ", r.max_disparity)});
  const cv::Size matching = experiment::MatchingSize(size, matching_width);
  r.summary.push_back(
      {"matched at",
       matching == size
           ? std::string("full size")
           : absl::StrCat(matching.width, " x ", matching.height,
                          " (matching_width; disparities resized back)")});
  absl::StatusOr<std::string> rect =
      io::ReadFileBytes(c.dir() / "exposures/rectification.txt");
  if (rect.ok()) r.summary.push_back({"rectification", *rect});

  r.hdr_preview = (c.dir() / ToneMappedFile(Method::kReinhard, 0)).string();
  for (Method m : experiment::ToneMappedMethods()) {
    r.tonemapped.push_back({experiment::MethodName(m),
                            {(c.dir() / ToneMappedFile(m, 0)).string(),
                             (c.dir() / ToneMappedFile(m, 1)).string()}});
  }
  ASSIGN_OR_RETURN(const std::vector<Truth> truths, c.Truths());
  for (const Truth& t : truths) {
    r.truths.push_back({t.name, t.disparity, t.mask0nocc});
  }
  for (Method m : experiment::SessionMethods()) {
    ASSIGN_OR_RETURN(const cv::Mat d, c.ReadPfm(DisparityFile(m)));
    r.disparities.push_back({experiment::MethodName(m), d});
  }
  r.error_options = error_options;
  ASSIGN_OR_RETURN(const std::vector<Metric> rows,
                   ReadMetricsFile(c.dir() / kMetricsFile));
  r.metrics = MetricsTable(rows);

  ASSIGN_OR_RETURN(const report::SessionReport page,
                   report::BuildSessionReport(r));
  for (const report::ReportFile& f : page.files) {
    const std::string rel = absl::StrCat("report/", f.name);
    if (f.copy_from.empty()) {
      RETURN_IF_ERROR(c.outputs().WriteImage("report", rel, f.image));
    } else {
      ASSIGN_OR_RETURN(io::DecodedImage image,
                       io::DecodeImageFile(f.copy_from));
      if (image.pixels.cols > report::kMaxFigureWidth) {
        RETURN_IF_ERROR(c.outputs().WriteImage("report", rel,
                                               report::FigureOf(image.pixels)));
        continue;
      }
      ASSIGN_OR_RETURN(const std::string bytes, io::ReadFileBytes(f.copy_from));
      RETURN_IF_ERROR(c.outputs().WriteText("report", rel, bytes));
    }
  }
  return c.outputs().WriteText("report", "report/index.html",
                               report::RenderPage(page.page));
}

}  // namespace

absl::StatusOr<ConfiguredStep> ConfigureEvaluate(const StepContext& c) {
  experiment::ExperimentOptions options;
  options.evaluation = c.options().experiment.evaluation;
  return ConfiguredStep{options.evaluation, [options](StepContext& c) {
                          return RunEvaluate(options, c);
                        }};
}

absl::StatusOr<ConfiguredStep> ConfigureExport(const StepContext& c) {
  nlohmann::json params = {{"baseline_mm", c.input().baseline_mm},
                           {"intrinsics", nullptr}};
  if (const auto& k = c.input().intrinsics) {
    params["intrinsics"] = {k->fx, k->fy, k->cx, k->cy};
  }
  return ConfiguredStep{params, &RunExport};
}

absl::StatusOr<ConfiguredStep> ConfigureReport(const StepContext& c) {
  const SessionInput& in = c.input();
  // Everything the page shows that is not in an input file.
  std::string page = absl::StrCat(in.session_name, "\n",
                                  absl::StrFormat("%.17g", in.baseline_mm),
                                  "\n", in.frames.size(), "\n");
  for (const auto& [key, value] : in.capture_summary) {
    absl::StrAppend(&page, key, "\t", value, "\n");
  }
  const eval::EvalOptions error_options = c.options().experiment.evaluation;
  const int matching_width = c.options().experiment.matching_width;
  return ConfiguredStep{{{"page", io::Sha256Hex(page)},
                         {"error_maps", error_options},
                         {"matching_width", matching_width}},
                        [error_options, matching_width](StepContext& c) {
                          return RunReport(error_options, matching_width, c);
                        }};
}

}  // namespace hdrstereo::pipeline
