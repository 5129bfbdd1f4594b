// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/experiment/thesis_table.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/eval/disparity_eval.h"
#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"
#include "processing/stereo/cost_volume_stereo.h"
#include "processing/tonemap/tonemap.h"

namespace hdrstereo::fusion {
namespace {

absl::StatusOr<TableRow> Score(const std::string& name, const cv::Mat& disp,
                               const TableInput& in) {
  eval::EvalOptions o;
  o.gt_zero_valid = true;
  absl::StatusOr<eval::DisparityEvaluation> e =
      eval::EvaluateDisparity(disp, in.truth, in.nonoccluded, cv::Mat(), o);
  if (!e.ok()) return e.status();
  TableRow row;
  row.name = name;
  row.rmse = e->nonoccluded.rmse;
  // thresholds {0.5, 1, 2, 4}: index 1 is "error > 1 px".
  row.bad1 = e->nonoccluded.bad_percent.at(1);
  return row;
}

struct Candidate {
  cv::Mat disparity;
  cv::Mat confidence;
};

absl::StatusOr<Candidate> Match(const cv::Mat& left, const cv::Mat& right,
                                stereo::StereoOptions o, int max_disp,
                                double inconsistent_confidence) {
  o.max_disparity = max_disp;
  absl::StatusOr<stereo::StereoResult> r =
      stereo::ComputeDisparity(left, right, o);
  if (!r.ok()) return r.status();
  Candidate c;
  c.disparity = r->disparity;
  c.confidence =
      cv::Mat(left.size(), CV_32FC1,
              cv::Scalar(static_cast<float>(inconsistent_confidence)));
  c.confidence.setTo(1.0f, r->consistent);
  return c;
}

absl::StatusOr<TableResult> RunImpl(const TableInput& in,
                                    const TableOptions& options) {
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
  int max_disp = in.max_disp;
  if (max_disp <= 0) {
    double hi = 0;
    cv::Mat finite = in.truth < std::numeric_limits<float>::infinity();
    cv::minMaxLoc(in.truth, nullptr, &hi, nullptr, nullptr, finite);
    max_disp = static_cast<int>(std::ceil(hi)) + 2;
  }
  const int ldr = in.ldr_index >= 0 ? in.ldr_index : static_cast<int>(n / 2);
  if (ldr >= static_cast<int>(n)) {
    return absl::InvalidArgumentError("table: ldr_index out of range");
  }

  absl::StatusOr<hdr::CameraResponse> response = hdr::RecoverResponse(in.left);
  if (!response.ok()) return response.status();
  absl::StatusOr<hdr::MergeResult> ml = hdr::MergeStack(in.left, *response);
  if (!ml.ok()) return ml.status();
  absl::StatusOr<hdr::MergeResult> mr = hdr::MergeStack(in.right, *response);
  if (!mr.ok()) return mr.status();

  TableResult result;
  result.name = in.name;
  auto add = [&](const std::string& name, const cv::Mat& disp) -> absl::Status {
    absl::StatusOr<TableRow> row = Score(name, disp, in);
    if (!row.ok()) return row.status();
    result.rows.push_back(*row);
    result.disparity[name] = disp;
    return absl::OkStatus();
  };

  const stereo::StereoOptions ldr_options;
  const double ic = options.inconsistent_confidence;
  absl::StatusOr<Candidate> ldr_c = Match(
      in.left.images[static_cast<size_t>(ldr)],
      in.right.images[static_cast<size_t>(ldr)], ldr_options, max_disp, ic);
  if (!ldr_c.ok()) return ldr_c.status();
  if (absl::Status s = add("LDR", ldr_c->disparity); !s.ok()) return s;

  std::vector<cv::Mat> cands, confs;
  cv::Mat guide;
  for (tonemap::Operator op : tonemap::AllOperators()) {
    absl::StatusOr<std::pair<cv::Mat, cv::Mat>> pair =
        tonemap::ToneMapPair(ml->radiance, mr->radiance, op);
    if (!pair.ok()) return pair.status();
    absl::StatusOr<Candidate> c =
        Match(pair->first, pair->second, ldr_options, max_disp, ic);
    if (!c.ok()) return c.status();
    if (absl::Status s = add(tonemap::OperatorName(op), c->disparity);
        !s.ok()) {
      return s;
    }
    cands.push_back(c->disparity);
    confs.push_back(c->confidence);
  }

  stereo::StereoOptions hdr_options = stereo::StereoOptions::Hdr();
  absl::StatusOr<Candidate> hdr_c =
      Match(ml->radiance, mr->radiance, hdr_options, max_disp, ic);
  if (!hdr_c.ok()) return hdr_c.status();
  if (absl::Status s = add("HDR-CVF", hdr_c->disparity); !s.ok()) return s;

  absl::StatusOr<cv::Mat> mean = FuseMean(cands, max_disp);
  if (!mean.ok()) return mean.status();
  if (absl::Status s = add("mean", *mean); !s.ok()) return s;
  absl::StatusOr<cv::Mat> median = FuseMedian(cands, max_disp);
  if (!median.ok()) return median.status();
  if (absl::Status s = add("median", *median); !s.ok()) return s;

  // The guide: the LDR middle exposure's left view (Appendix A: left.jpg).
  guide = in.left.images[static_cast<size_t>(ldr)];
  if (guide.depth() == CV_16U) guide.convertTo(guide, CV_8U, 1.0 / 257.0);
  FusionParams fp = options.fusion;
  fp.max_disp = max_disp;

  // fused-4: every 4-subset of the 7 (35), RMSE and bad-1px averaged.
  TableRow f4;
  f4.name = "fused-4";
  int subsets = 0;
  const int k = static_cast<int>(cands.size());
  for (int mask = 0; mask < (1 << k); ++mask) {
    if (std::popcount(static_cast<unsigned>(mask)) != 4) continue;
    std::vector<cv::Mat> c4, w4;
    for (int i = 0; i < k; ++i) {
      if ((mask >> i) & 1) {
        c4.push_back(cands[static_cast<size_t>(i)]);
        w4.push_back(confs[static_cast<size_t>(i)]);
      }
    }
    absl::StatusOr<FusionResult> r = FuseAlphaExpansion(c4, guide, fp, w4);
    if (!r.ok()) return r.status();
    absl::StatusOr<TableRow> row = Score("fused-4", r->disparity, in);
    if (!row.ok()) return row.status();
    f4.rmse += row->rmse;
    f4.bad1 += row->bad1;
    ++subsets;
    if (!options.fused4_all_subsets) break;
  }
  f4.rmse /= subsets;
  f4.bad1 /= subsets;
  result.rows.push_back(f4);

  absl::StatusOr<FusionResult> f7 = FuseAlphaExpansion(cands, guide, fp, confs);
  if (!f7.ok()) return f7.status();
  result.fused7_stats = f7->stats;
  if (absl::Status s = add("fused-7", f7->disparity); !s.ok()) return s;
  return result;
}

std::string Fixed(double v, int digits) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, v);
  return buf;
}

double MeanOf(const std::vector<TableResult>& results, const std::string& name,
              bool rmse) {
  double sum = 0;
  int count = 0;
  for (const TableResult& r : results) {
    for (const TableRow& row : r.rows) {
      if (row.name == name) {
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

double MeanRmse(const std::vector<TableResult>& results,
                const std::string& name) {
  return MeanOf(results, name, true);
}

double MeanBad1(const std::vector<TableResult>& results,
                const std::string& name) {
  return MeanOf(results, name, false);
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
    absl::StrAppend(&out, "| ", first.name, " |");
    for (const TableResult& r : results) {
      for (const TableRow& row : r.rows) {
        if (row.name == first.name) {
          absl::StrAppend(&out, " ", Fixed(row.rmse, 2), " | ",
                          Fixed(row.bad1, 1), " |");
        }
      }
    }
    absl::StrAppend(&out, " ", Fixed(MeanRmse(results, first.name), 2), " | ",
                    Fixed(MeanBad1(results, first.name), 1), " |\n");
  }
  return out;
}

}  // namespace hdrstereo::fusion
