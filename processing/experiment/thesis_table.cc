// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/experiment/thesis_table.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/base/parallel_for.h"
#include "processing/base/status_macros.h"
#include "processing/io/image.h"

namespace hdrstereo::experiment {
namespace {

absl::StatusOr<TableRow> ScoreRow(Method method, const cv::Mat& disp,
                                  const TableInput& in,
                                  const ExperimentOptions& options) {
  ASSIGN_OR_RETURN(const eval::RegionMetrics r,
                   Score(disp, in.truth, in.nonoccluded, options));
  // thresholds {0.5, 1, 2, 4}: index 1 is "error > 1 px".
  return TableRow{method, r.rmse, r.bad_percent.at(1)};
}

// fused-4: every 4-subset of the 7 (35), RMSE and bad-1px averaged.
absl::StatusOr<TableRow> Fused4(const std::map<Method, Candidate>& candidates,
                                const FusionViews& views, int max_disp,
                                const TableInput& in,
                                const TableOptions& options) {
  const std::vector<Method>& seven = ToneMappedMethods();
  const int k = static_cast<int>(seven.size());
  std::vector<unsigned> subsets;
  for (unsigned mask = 0; mask < (1u << k); ++mask) {
    if (std::popcount(mask) != 4) continue;
    subsets.push_back(mask);
    if (!options.fused4_all_subsets) break;
  }
  std::vector<TableRow> rows(subsets.size());
  RETURN_IF_ERROR(ParallelFor(
      static_cast<int>(subsets.size()), options.threads,
      [&](int s) -> absl::Status {
        std::vector<const Candidate*> four;
        for (int i = 0; i < k; ++i) {
          if ((subsets[static_cast<size_t>(s)] >> i) & 1) {
            four.push_back(&candidates.at(seven[static_cast<size_t>(i)]));
          }
        }
        ASSIGN_OR_RETURN(const fusion::FusionResult r,
                         FuseSome(four, views, max_disp, options.experiment));
        ASSIGN_OR_RETURN(
            rows[static_cast<size_t>(s)],
            ScoreRow(Method::kFused4, r.disparity, in, options.experiment));
        return absl::OkStatus();
      }));
  TableRow f4{Method::kFused4, 0, 0};
  for (const TableRow& r : rows) {
    f4.rmse += r.rmse;
    f4.bad1 += r.bad1;
  }
  f4.rmse /= static_cast<double>(rows.size());
  f4.bad1 /= static_cast<double>(rows.size());
  return f4;
}

// The regions of DetailRow, as masks in its order.
std::vector<std::pair<std::string, cv::Mat>> Regions(const cv::Mat& ldr_left,
                                                     int max_disp) {
  cv::Mat grey = io::To8Bit(ldr_left);
  if (grey.channels() == 3) cv::cvtColor(grey, grey, cv::COLOR_BGR2GRAY);
  const cv::Size size = grey.size();
  cv::Mat small;
  const int small_w = std::min(kReferenceWidth, size.width);
  cv::resize(grey, small,
             cv::Size(small_w, std::max(1, size.height * small_w / size.width)),
             0, 0, cv::INTER_AREA);
  cv::Mat gx, gy, mag;
  cv::Sobel(small, gx, CV_32F, 1, 0);
  cv::Sobel(small, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, mag);
  cv::blur(mag, mag, cv::Size(9, 9));
  cv::Mat low = mag < 20;
  cv::resize(low, low, size, 0, 0, cv::INTER_NEAREST);
  cv::Mat taken = cv::Mat::zeros(size, CV_8UC1);
  std::vector<std::pair<std::string, cv::Mat>> out;
  auto add = [&](const std::string& name, cv::Mat m) {
    m &= ~taken;
    taken |= m;
    out.emplace_back(name, m);
  };
  cv::Mat band = cv::Mat::zeros(size, CV_8UC1);
  band.colRange(0, std::min(max_disp, size.width)).setTo(255);
  add("left band", band);
  add("saturated", grey >= 250);
  add("dark", grey <= 10);
  add("low texture", low);
  add("textured", cv::Mat(size, CV_8UC1, cv::Scalar(255)));
  return out;
}

absl::StatusOr<DetailRow> Detail(
    const std::string& approach, const cv::Mat& disp, const TableInput& in,
    const std::vector<std::pair<std::string, cv::Mat>>& regions,
    const ExperimentOptions& options) {
  eval::EvalOptions e = options.evaluation;
  const double scaled = static_cast<double>(in.truth.cols) / kReferenceWidth;
  e.thresholds = {1.0, 2.0, scaled};
  ASSIGN_OR_RETURN(
      const eval::DisparityEvaluation all,
      eval::EvaluateDisparity(disp, in.truth, in.nonoccluded, cv::Mat(), e));
  DetailRow row{approach,
                all.nonoccluded.rmse,
                all.nonoccluded.bad_percent[0],
                all.nonoccluded.bad_percent[1],
                all.nonoccluded.bad_percent[2],
                {}};
  for (const auto& [name, mask] : regions) {
    ASSIGN_OR_RETURN(
        const eval::DisparityEvaluation r,
        eval::EvaluateDisparity(disp, in.truth, in.nonoccluded, mask, e));
    const double share = all.nonoccluded.pixels == 0
                             ? 0
                             : 100.0 *
                                   static_cast<double>(r.nonoccluded.pixels) /
                                   static_cast<double>(all.nonoccluded.pixels);
    row.regions.push_back(
        {name, share, r.nonoccluded.rmse,
         r.nonoccluded.pixels == 0 ? 0 : r.nonoccluded.bad_percent[0]});
  }
  return row;
}

// Per pixel, the candidate of the seven closest to the truth (compared as
// scored: times the evaluation's disparity_scale).
cv::Mat Oracle(const std::map<Method, cv::Mat>& disparity, const cv::Mat& truth,
               double disparity_scale) {
  cv::Mat best(truth.size(), CV_32FC1,
               cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  std::vector<const cv::Mat*> seven;
  for (Method m : ToneMappedMethods()) seven.push_back(&disparity.at(m));
  for (int y = 0; y < truth.rows; ++y) {
    const float* t = truth.ptr<float>(y);
    float* out = best.ptr<float>(y);
    for (int x = 0; x < truth.cols; ++x) {
      double best_error = std::numeric_limits<double>::infinity();
      for (const cv::Mat* c : seven) {
        const float z = c->ptr<float>(y)[x];
        const double error = std::abs(z * disparity_scale - t[x]);
        if (error < best_error) {
          best_error = error;
          out[x] = z;
        }
      }
    }
  }
  return best;
}

absl::StatusOr<std::vector<DetailRow>> Details(const TableResult& result,
                                               const TableInput& in,
                                               int max_disp, size_t ldr,
                                               const ExperimentOptions& o) {
  const auto regions = Regions(in.left.images[ldr], max_disp);
  std::vector<DetailRow> rows;
  for (const TableRow& r : result.rows) {
    auto it = result.disparity.find(r.method);
    if (it == result.disparity.end()) continue;  // fused-4: a mean of runs
    ASSIGN_OR_RETURN(DetailRow row,
                     Detail(MethodName(r.method), it->second, in, regions, o));
    rows.push_back(std::move(row));
  }
  ASSIGN_OR_RETURN(
      DetailRow oracle,
      Detail("oracle",
             Oracle(result.disparity, in.truth, o.evaluation.disparity_scale),
             in, regions, o));
  rows.push_back(std::move(oracle));
  return rows;
}

absl::StatusOr<TableResult> RunImpl(const TableInput& in,
                                    const TableOptions& options) {
  const ExperimentOptions& o = options.experiment;
  RETURN_IF_ERROR(o.Validate());
  const size_t n = in.left.images.size();
  if (n < 2 || in.right.images.size() != n || in.left.exposure_s.size() != n ||
      in.right.exposure_s != in.left.exposure_s) {
    return absl::InvalidArgumentError(
        "table: left and right stacks need the same >= 2 exposures");
  }
  if (in.truth.type() != CV_32FC1 ||
      in.truth.size() != in.left.images[0].size()) {
    return absl::InvalidArgumentError(
        "table: the truth must be CV_32FC1 of the images' size");
  }
  const int width = in.truth.cols;
  const int max_disp = in.max_disp > 0
                           ? in.max_disp
                           : DisparityRange(LargestDisparity(in.truth), width);
  const size_t ldr =
      in.ldr_index >= 0 ? static_cast<size_t>(in.ldr_index) : n / 2;
  if (ldr >= n) {
    return absl::InvalidArgumentError("table: ldr_index out of range");
  }
  const UnitRunner runner = [&](const std::vector<std::string>& names,
                                const std::function<absl::Status(int)>& unit) {
    return ParallelFor(static_cast<int>(names.size()), options.threads, unit);
  };

  ASSIGN_OR_RETURN(const hdr::CameraResponse response, ResponseOf(in.left, o));
  ASSIGN_OR_RETURN(const cv::Mat left, RadianceOf(in.left, response, o));
  ASSIGN_OR_RETURN(const cv::Mat right, RadianceOf(in.right, response, o));
  std::map<Method, StereoPair> pairs;
  pairs[Method::kLdr] = {in.left.images[ldr], in.right.images[ldr]};
  for (Method m : ToneMappedMethods()) {
    ASSIGN_OR_RETURN(pairs[m], ToneMapped(m, left, right, o));
  }
  pairs[Method::kHdr] = {left, right};
  ASSIGN_OR_RETURN(const auto candidates,
                   MatchAllMethods(pairs, max_disp, o, runner));
  const FusionViews views{io::To8Bit(in.left.images[ldr]),
                          pairs.at(kFusionView).left,
                          pairs.at(kFusionView).right};
  ASSIGN_OR_RETURN(const Fused fused,
                   FuseMethods(candidates, views, max_disp, o, runner));

  TableResult result;
  result.name = in.name;
  result.width = width;
  result.fused_stats = fused.stats;
  for (const auto& [m, c] : candidates) result.disparity[m] = c.disparity;
  for (const auto& [m, d] : fused.disparity) result.disparity[m] = d;
  for (Method m : MatchedMethods()) {
    ASSIGN_OR_RETURN(TableRow row, ScoreRow(m, result.disparity[m], in, o));
    result.rows.push_back(row);
  }
  for (Method m : {Method::kMean, Method::kMedian}) {
    ASSIGN_OR_RETURN(TableRow row, ScoreRow(m, result.disparity[m], in, o));
    result.rows.push_back(row);
  }
  ASSIGN_OR_RETURN(TableRow f4,
                   Fused4(candidates, views, max_disp, in, options));
  result.rows.push_back(f4);
  ASSIGN_OR_RETURN(
      TableRow f7,
      ScoreRow(Method::kFused, result.disparity[Method::kFused], in, o));
  result.rows.push_back(f7);
  if (options.details) {
    ASSIGN_OR_RETURN(result.details, Details(result, in, max_disp, ldr, o));
  }
  return result;
}

std::string Fixed(double v, int digits) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

double MeanOf(const std::vector<TableResult>& results, Method method,
              bool rmse) {
  double sum = 0;
  int count = 0;
  for (const TableResult& r : results) {
    for (const TableRow& row : r.rows) {
      if (row.method == method) {
        sum += rmse ? row.rmse : row.bad1;
        ++count;
      }
    }
  }
  return count == 0 ? -1 : sum / count;
}

}  // namespace

absl::StatusOr<TableResult> RunThesisTable(const TableInput& input,
                                           const TableOptions& options) {
  try {
    return RunImpl(input, options);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("table: OpenCV: ", e.what()));
  }
}

std::string FormatDetails(const std::vector<TableResult>& results) {
  std::string out;
  for (const TableResult& r : results) {
    if (r.details.empty()) continue;
    const DetailRow& first = r.details.front();
    absl::StrAppend(&out, "\n", r.name, " (", r.width, " px; scaled = bad-",
                    Fixed(static_cast<double>(r.width) / kReferenceWidth, 2),
                    "px; per region RMSE / bad-1px %)\n\n| approach | RMSE | "
                    "bad-1px % | bad-2px % | scaled % |");
    std::string rule = "|---|---:|---:|---:|---:|";
    for (const RegionScore& region : first.regions) {
      absl::StrAppend(&out, " ", region.region, " (", Fixed(region.share, 1),
                      " %) |");
      absl::StrAppend(&rule, "---:|");
    }
    absl::StrAppend(&out, "\n", rule, "\n");
    for (const DetailRow& row : r.details) {
      absl::StrAppend(&out, "| ", row.approach, " | ", Fixed(row.rmse, 2),
                      " | ", Fixed(row.bad1, 1), " | ", Fixed(row.bad2, 1),
                      " | ", Fixed(row.scaled, 1), " |");
      for (const RegionScore& region : row.regions) {
        absl::StrAppend(&out, " ", Fixed(region.rmse, 2), " / ",
                        Fixed(region.bad1, 1), " |");
      }
      absl::StrAppend(&out, "\n");
    }
  }
  return out;
}

double MeanRmse(const std::vector<TableResult>& results, Method method) {
  return MeanOf(results, method, true);
}

double MeanBad1(const std::vector<TableResult>& results, Method method) {
  return MeanOf(results, method, false);
}

std::string FormatTable(const std::vector<TableResult>& results) {
  if (results.empty()) return "";
  std::string out = "| approach |";
  std::string rule = "|---|";
  for (const TableResult& r : results) {
    absl::StrAppend(&out, " ", r.name, " RMSE | ", r.name, " bad-1px % |");
    absl::StrAppend(&rule, "---:|---:|");
  }
  absl::StrAppend(&out, " mean RMSE | mean bad-1px % |\n");
  absl::StrAppend(&rule, "---:|---:|\n");
  out += rule;
  for (const TableRow& first : results[0].rows) {
    absl::StrAppend(&out, "| ", MethodName(first.method), " |");
    for (const TableResult& r : results) {
      for (const TableRow& row : r.rows) {
        if (row.method == first.method) {
          absl::StrAppend(&out, " ", Fixed(row.rmse, 2), " | ",
                          Fixed(row.bad1, 1), " |");
        }
      }
    }
    absl::StrAppend(&out, " ", Fixed(MeanRmse(results, first.method), 2), " | ",
                    Fixed(MeanBad1(results, first.method), 1), " |\n");
  }
  return out;
}

}  // namespace hdrstereo::experiment
