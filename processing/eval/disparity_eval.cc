// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/eval/disparity_eval.h"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::eval {

absl::Status EvalOptions::Validate() const {
  for (size_t i = 0; i < thresholds.size(); ++i) {
    RETURN_IF_ERROR(RequireField(
        thresholds[i] >= 0 && std::isfinite(thresholds[i]),
        absl::StrCat("thresholds[", i, "]"), thresholds[i], ">= 0 (px)"));
  }
  return RequireField(disparity_scale > 0 && std::isfinite(disparity_scale),
                      "disparity_scale", disparity_scale, "> 0");
}

void to_json(nlohmann::json& j, const EvalOptions& o) {
  const auto& [thresholds, gt_zero_valid, disparity_scale] = o;
  j = nlohmann::json{{"thresholds", thresholds},
                     {"gt_zero_valid", gt_zero_valid},
                     {"disparity_scale", disparity_scale}};
}

namespace {

absl::Status CheckMask(const cv::Mat& m, const cv::Size& size,
                       const char* what) {
  if (m.empty()) return absl::OkStatus();
  if (m.type() != CV_8UC1 || m.size() != size) {
    return absl::InvalidArgumentError(absl::StrCat(
        what,
        " must be an 8-bit single-channel image of the disparity's size"));
  }
  return absl::OkStatus();
}

bool GtValid(float g, const EvalOptions& o) {
  return std::isfinite(g) && (o.gt_zero_valid || g > 0);
}

struct Accumulator {
  int64_t pixels = 0, estimated = 0;
  double sq = 0, abs = 0;
  std::vector<int64_t> bad;

  void Add(bool has_estimate, double err, const std::vector<double>& t) {
    ++pixels;
    if (!has_estimate) {
      for (int64_t& b : bad) ++b;
      return;
    }
    ++estimated;
    sq += err * err;
    abs += err;
    for (size_t i = 0; i < t.size(); ++i) {
      if (err > t[i]) ++bad[i];
    }
  }

  RegionMetrics Finish() const {
    RegionMetrics m;
    m.pixels = pixels;
    m.estimated = estimated;
    m.coverage = pixels ? static_cast<double>(estimated) / pixels : 0.0;
    m.rmse = estimated ? std::sqrt(sq / estimated) : 0.0;
    m.mae = estimated ? abs / estimated : 0.0;
    for (int64_t b : bad) {
      m.bad_percent.push_back(pixels ? 100.0 * b / pixels : 0.0);
    }
    return m;
  }
};

nlohmann::json RegionJson(const RegionMetrics& m,
                          const std::vector<double>& thresholds) {
  nlohmann::json bad = nlohmann::json::object();
  for (size_t i = 0; i < thresholds.size() && i < m.bad_percent.size(); ++i) {
    bad[absl::StrFormat("%g", thresholds[i])] = m.bad_percent[i];
  }
  return {{"pixels", m.pixels},     {"estimated", m.estimated},
          {"coverage", m.coverage}, {"rmse", m.rmse},
          {"mae", m.mae},           {"bad", bad}};
}

}  // namespace

absl::StatusOr<DisparityEvaluation> EvaluateDisparity(
    const cv::Mat& disparity, const cv::Mat& truth, const cv::Mat& nonoccluded,
    const cv::Mat& mask, const EvalOptions& options) {
  if (disparity.empty() || truth.empty()) {
    return absl::InvalidArgumentError("disparity or ground truth is empty");
  }
  if (disparity.type() != CV_32FC1 || truth.type() != CV_32FC1) {
    return absl::InvalidArgumentError(
        "disparity and ground truth must be single-channel float");
  }
  if (disparity.size() != truth.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("disparity (", disparity.cols, "x", disparity.rows,
                     ") and ground truth (", truth.cols, "x", truth.rows,
                     ") differ in size"));
  }
  RETURN_IF_ERROR(CheckMask(nonoccluded, truth.size(), "non-occlusion mask"));
  RETURN_IF_ERROR(CheckMask(mask, truth.size(), "mask"));
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("evaluation: ", s.message()));
  }
  const std::vector<double>& t = options.thresholds;
  Accumulator all, nonocc, valid;
  all.bad.assign(t.size(), 0);
  nonocc.bad.assign(t.size(), 0);
  valid.bad.assign(t.size(), 0);
  for (int y = 0; y < truth.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const float* g = truth.ptr<float>(y);
    const uint8_t* no =
        nonoccluded.empty() ? nullptr : nonoccluded.ptr<uint8_t>(y);
    const uint8_t* mk = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    for (int x = 0; x < truth.cols; ++x) {
      if (mk != nullptr && mk[x] == 0) continue;
      if (!GtValid(g[x], options)) continue;
      const double est = static_cast<double>(d[x]) * options.disparity_scale;
      const bool has = std::isfinite(est);
      const double err = has ? std::abs(est - g[x]) : 0.0;
      all.Add(has, err, t);
      if (no == nullptr || no[x] != 0) nonocc.Add(has, err, t);
      if (has) valid.Add(true, err, t);
    }
  }
  DisparityEvaluation e;
  e.thresholds = t;
  e.all = all.Finish();
  e.nonoccluded = nonocc.Finish();
  e.valid = valid.Finish();
  return e;
}

std::string EvaluationToJson(const DisparityEvaluation& e) {
  const nlohmann::json j = {
      {"thresholds", e.thresholds},
      {"all", RegionJson(e.all, e.thresholds)},
      {"nonoccluded", RegionJson(e.nonoccluded, e.thresholds)},
      {"valid", RegionJson(e.valid, e.thresholds)}};
  // No strings but the keys, all ASCII: dump cannot throw.
  return j.dump(2);
}

std::string EvaluationToText(const DisparityEvaluation& e) {
  std::string s = absl::StrFormat("%-12s %9s %8s %9s %9s", "region", "pixels",
                                  "coverage", "rmse", "mae");
  for (double th : e.thresholds)
    absl::StrAppend(&s, absl::StrFormat("  bad>%-4g", th));
  absl::StrAppend(&s, "\n");
  const std::pair<const char*, const RegionMetrics*> rows[] = {
      {"all", &e.all}, {"nonoccluded", &e.nonoccluded}, {"valid", &e.valid}};
  for (const auto& [name, m] : rows) {
    absl::StrAppend(
        &s, absl::StrFormat("%-12s %9d %7.2f%% %9.4f %9.4f", name, m->pixels,
                            100.0 * m->coverage, m->rmse, m->mae));
    for (double b : m->bad_percent)
      absl::StrAppend(&s, absl::StrFormat("  %7.3f%%", b));
    absl::StrAppend(&s, "\n");
  }
  return s;
}

absl::StatusOr<cv::Mat> ColorizeDisparity(const cv::Mat& disparity,
                                          double min_disp, double max_disp) {
  if (disparity.empty() || disparity.type() != CV_32FC1) {
    return absl::InvalidArgumentError(
        "disparity must be a non-empty single-channel float image");
  }
  try {
    cv::Mat finite = (disparity == disparity);  // false for NaN
    cv::Mat not_inf =
        cv::abs(disparity) < std::numeric_limits<float>::infinity();
    finite &= not_inf;
    if (min_disp >= max_disp) {
      cv::minMaxLoc(disparity, &min_disp, &max_disp, nullptr, nullptr, finite);
      if (min_disp >= max_disp) max_disp = min_disp + 1;
    }
    cv::Mat scaled;
    const double k = 255.0 / (max_disp - min_disp);
    cv::Mat clean = disparity.clone();
    clean.setTo(min_disp, ~finite);
    clean.convertTo(scaled, CV_8U, k, -min_disp * k);  // saturates
    cv::Mat out;
    cv::applyColorMap(scaled, out, cv::COLORMAP_VIRIDIS);
    out.setTo(cv::Scalar::all(0), ~finite);
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("colorize: ", e.what()));
  }
}

absl::StatusOr<cv::Mat> ColorizeError(const cv::Mat& disparity,
                                      const cv::Mat& truth, double max_error,
                                      const EvalOptions& options) {
  if (disparity.empty() || disparity.type() != CV_32FC1 ||
      truth.type() != CV_32FC1 || truth.size() != disparity.size()) {
    return absl::InvalidArgumentError(
        "disparity and truth must be single-channel float of one size");
  }
  if (!(max_error > 0))
    return absl::InvalidArgumentError("max_error must be > 0");
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("evaluation: ", s.message()));
  }
  try {
    cv::Mat scaled(disparity.size(), CV_8UC1);
    cv::Mat invalid(disparity.size(), CV_8UC1, cv::Scalar(0));
    for (int y = 0; y < disparity.rows; ++y) {
      const float* d = disparity.ptr<float>(y);
      const float* g = truth.ptr<float>(y);
      uint8_t* s = scaled.ptr<uint8_t>(y);
      uint8_t* inv = invalid.ptr<uint8_t>(y);
      for (int x = 0; x < disparity.cols; ++x) {
        const double est = d[x] * options.disparity_scale;
        if (!std::isfinite(est) || !GtValid(g[x], options)) {
          inv[x] = 255;
          s[x] = 0;
          continue;
        }
        const double e = std::min(std::abs(est - g[x]) / max_error, 1.0);
        s[x] = static_cast<uint8_t>(std::lround(255.0 * e));
      }
    }
    cv::Mat out;
    cv::applyColorMap(scaled, out, cv::COLORMAP_PLASMA);
    out.setTo(cv::Scalar::all(0), invalid);
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("colorize: ", e.what()));
  }
}

}  // namespace hdrstereo::eval
