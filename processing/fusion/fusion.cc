// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/fusion.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <new>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

// libmaxflow's headers come in as SYSTEM (imported target PkgConfig::MAXFLOW).
#include <maxflow.h>

namespace hdrstereo::fusion {
namespace {

using Graph = maxflow::Graph<int, int, int>;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

[[noreturn]] void MaxflowError(const char* /*message*/) {
  throw std::bad_alloc();
}

// Rounds a non-negative cost (std::lround is slow in the inner loops).
inline int32_t Round(double v) { return static_cast<int32_t>(v + 0.5); }

inline int32_t Rho(const MrfProblem& pr, int32_t a, int32_t b) {
  if (pr.potts) return a != b ? 1 : 0;
  const int64_t d = static_cast<int64_t>(a) - b;
  return static_cast<int32_t>(std::min<int64_t>(d * d, pr.truncation));
}

inline int32_t RhoMax(const MrfProblem& pr) {
  return pr.potts ? 1 : pr.truncation;
}

absl::Status CheckCandidates(const std::vector<cv::Mat>& candidates,
                             int max_disp) {
  RETURN_IF_ERROR(CheckCandidateMaps(candidates));
  if (max_disp < 1 || max_disp > 4096) {
    return absl::InvalidArgumentError(
        absl::StrCat("fusion: max_disp must be in [1, 4096], got ", max_disp));
  }
  return absl::OkStatus();
}

// MATLAB's edge(I) with its defaults, per channel of an 8-bit image, ORed
// (Appendix A compute_color_edge): Sobel gradients / 8, b = gx^2 + gy^2,
// cut-off 4 * mean(b); a pixel is an edge where b exceeds the cut-off and is
// a local maximum across its stronger gradient direction (thinning).
cv::Mat EdgeMask(const cv::Mat& image8) {
  std::vector<cv::Mat> channels;
  cv::split(image8, channels);
  cv::Mat mask = cv::Mat::zeros(image8.size(), CV_8UC1);
  const int w = image8.cols, h = image8.rows;
  for (const cv::Mat& c : channels) {
    cv::Mat f, gx, gy;
    c.convertTo(f, CV_32F, 1.0 / 255.0);
    cv::Sobel(f, gx, CV_32F, 1, 0, 3, 1.0 / 8.0, 0, cv::BORDER_REPLICATE);
    cv::Sobel(f, gy, CV_32F, 0, 1, 3, 1.0 / 8.0, 0, cv::BORDER_REPLICATE);
    const cv::Mat b = gx.mul(gx) + gy.mul(gy);
    const float cutoff = static_cast<float>(4.0 * cv::mean(b)[0]);
    auto at = [&](int y, int x) {
      return (x < 0 || x >= w || y < 0 || y >= h) ? 0.0f : b.at<float>(y, x);
    };
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const float v = b.at<float>(y, x);
        if (!(v > cutoff)) continue;
        const float ax = std::abs(gx.at<float>(y, x));
        const float ay = std::abs(gy.at<float>(y, x));
        const bool across_x = ax >= ay && at(y, x - 1) <= v && v > at(y, x + 1);
        const bool across_y = ay >= ax && at(y - 1, x) <= v && v > at(y + 1, x);
        if (across_x || across_y) mask.at<uchar>(y, x) = 1;
      }
    }
  }
  return mask;
}

absl::StatusOr<cv::Mat> GuideGrey8(const cv::Mat& guide, cv::Size size) {
  if (guide.empty() || guide.size() != size) {
    return absl::InvalidArgumentError(
        absl::StrCat("fusion: the guide must be ", size.width, "x", size.height,
                     ", got ", guide.cols, "x", guide.rows));
  }
  const int depth = guide.depth();
  const int ch = guide.channels();
  if ((depth != CV_8U && depth != CV_32F) || (ch != 1 && ch != 3)) {
    return absl::InvalidArgumentError(
        "fusion: the guide must be 8-bit or float [0, 1], 1 or 3 channels");
  }
  cv::Mat grey = guide;
  if (ch == 3) cv::cvtColor(guide, grey, cv::COLOR_BGR2GRAY);
  if (depth == CV_32F) {
    cv::Mat g8;
    grey.convertTo(g8, CV_8U, 255.0);
    grey = g8;
  }
  return grey.isContinuous() ? grey : grey.clone();
}

// Per-candidate data cost at offset d = l - z, before confidence and scale.
double UnitCost(const FusionOptions& params, double d) {
  if (params.data == DataModel::kGaussian) {
    return 1.0 - std::exp(-d * d / (2.0 * params.sigma * params.sigma));
  }
  return std::min(d * d, params.data_truncation);
}

double UnitCostMax(const FusionOptions& params) {
  return params.data == DataModel::kGaussian ? 1.0 : params.data_truncation;
}

absl::StatusOr<MrfProblem> BuildProblemImpl(
    const std::vector<cv::Mat>& candidates, const cv::Mat& guide,
    const FusionOptions& params, const std::vector<cv::Mat>& confidences) {
  RETURN_IF_ERROR(CheckCandidates(candidates, params.max_disp));
  if (absl::Status s = params.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("fusion: ", s.message()));
  }
  const int num_k = static_cast<int>(candidates.size());
  const double per_candidate_max =
      std::round(params.data_scale * UnitCostMax(params));
  if (per_candidate_max * num_k > 65535.0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "fusion: data_scale too large: ", num_k, " candidates x max cost ",
        per_candidate_max, " exceeds 65535"));
  }
  if (!confidences.empty()) {
    if (confidences.size() != candidates.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("fusion: ", confidences.size(), " confidence maps for ",
                       candidates.size(), " candidates"));
    }
    for (size_t k = 0; k < confidences.size(); ++k) {
      if (confidences[k].type() != CV_32FC1 ||
          confidences[k].size() != candidates[0].size()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "fusion: confidence ", k, " must be CV_32FC1 of the same size"));
      }
    }
  }
  const cv::Size size = candidates[0].size();
  ASSIGN_OR_RETURN(cv::Mat grey, GuideGrey8(guide, size));

  MrfProblem pr;
  pr.width = size.width;
  pr.height = size.height;
  pr.num_labels = params.max_disp + 1;
  const int64_t n = static_cast<int64_t>(pr.width) * pr.height;
  const int num_labels = pr.num_labels;
  if (n * num_labels > (int64_t{1} << 31)) {
    return absl::InvalidArgumentError(
        "fusion: image x labels too large (more than 2^31 data costs)");
  }

  // Data term: a constant per valid candidate, lowered inside a window
  // around z where the rounded cost differs from the maximum.
  const double cost_max = UnitCostMax(params);
  auto confidence = [&](int k, int64_t p) -> double {
    if (confidences.empty()) return 1.0;
    const float c = confidences[static_cast<size_t>(k)].ptr<float>()[p];
    return std::isfinite(c) ? std::clamp(static_cast<double>(c), 0.0, 1.0)
                            : 0.0;
  };
  std::vector<const float*> cand(static_cast<size_t>(num_k));
  std::vector<cv::Mat> cont(static_cast<size_t>(num_k));
  for (int k = 0; k < num_k; ++k) {
    cont[static_cast<size_t>(k)] =
        candidates[static_cast<size_t>(k)].isContinuous()
            ? candidates[static_cast<size_t>(k)]
            : candidates[static_cast<size_t>(k)].clone();
    cand[static_cast<size_t>(k)] = cont[static_cast<size_t>(k)].ptr<float>();
  }
  // Half-width of the window outside which the rounded cost is the maximum.
  int window = 1;
  while (window < num_labels &&
         std::lround(params.data_scale * UnitCost(params, window)) <
             std::lround(params.data_scale * cost_max)) {
    ++window;
  }
  // Unit cost by |l - z| in steps of 1 / kLutStep px (the candidate's
  // sub-pixel position is used to 1e-3 px).
  constexpr int kLutStep = 1024;
  std::vector<double> lut(static_cast<size_t>((window + 2) * kLutStep + 1));
  for (size_t i = 0; i < lut.size(); ++i) {
    lut[i] = UnitCost(params, static_cast<double>(i) / kLutStep);
  }
  // Without confidences: the integer saving below the maximum by offset.
  std::vector<int32_t> saving(lut.size());
  for (size_t i = 0; i < lut.size(); ++i) {
    saving[i] =
        Round(params.data_scale * cost_max) - Round(params.data_scale * lut[i]);
  }
  pr.far.resize(static_cast<size_t>(n));
  pr.near_begin.assign(static_cast<size_t>(n + 1), 0);
  // Pixel by pixel, rows in parallel: a candidate lowers the constant only
  // in its window, so only the windows' labels are computed (in a small
  // per-pixel buffer); those below the constant go to one vector per row,
  // then into the sparse data term.
  const int width = pr.width;
  std::vector<std::vector<MrfProblem::NearCost>> row_near(
      static_cast<size_t>(pr.height));
  std::atomic<bool> failed{false};
  cv::parallel_for_(cv::Range(0, pr.height), [&](const cv::Range& rows) {
    try {
      std::vector<int32_t> cost(static_cast<size_t>(num_labels));
      std::vector<std::pair<int, int>> spans;
      spans.reserve(static_cast<size_t>(num_k));
      for (int y = rows.start; y < rows.end; ++y) {
        const int64_t row0 = static_cast<int64_t>(y) * width;
        std::vector<MrfProblem::NearCost>& out =
            row_near[static_cast<size_t>(y)];
        for (int64_t p = row0; p < row0 + width; ++p) {
          int32_t b = 0;
          spans.clear();
          for (int k = 0; k < num_k; ++k) {
            const float z = cand[static_cast<size_t>(k)][p];
            if (!IsValidDisparity(z, params.max_disp)) continue;
            b += Round(params.data_scale * confidence(k, p) * cost_max);
            const int centre = static_cast<int>(z + 0.5f);
            spans.emplace_back(std::max(0, centre - window - 1),
                               std::min(num_labels - 1, centre + window + 1));
          }
          for (const auto& [lo, hi] : spans) {
            std::fill(cost.begin() + lo, cost.begin() + hi + 1, b);
          }
          for (int k = 0; k < num_k; ++k) {
            const float z = cand[static_cast<size_t>(k)][p];
            if (!IsValidDisparity(z, params.max_disp)) continue;
            const int centre = static_cast<int>(z + 0.5f);
            const int lo = std::max(0, centre - window - 1);
            const int hi = std::min(num_labels - 1, centre + window + 1);
            if (confidences.empty()) {
              for (int l = lo; l <= hi; ++l) {
                const size_t i = std::min(
                    static_cast<size_t>(
                        std::abs(static_cast<float>(l) - z) * kLutStep + 0.5f),
                    saving.size() - 1);
                cost[static_cast<size_t>(l)] -= saving[i];
              }
            } else {
              const double scale = params.data_scale * confidence(k, p);
              const int32_t full = Round(scale * cost_max);
              for (int l = lo; l <= hi; ++l) {
                const size_t i = std::min(
                    static_cast<size_t>(
                        std::abs(static_cast<float>(l) - z) * kLutStep + 0.5f),
                    lut.size() - 1);
                cost[static_cast<size_t>(l)] -= full - Round(scale * lut[i]);
              }
            }
          }
          // The windows' union, once, by ascending label.
          std::sort(spans.begin(), spans.end());
          const size_t first = out.size();
          int next = 0;  // labels below `next` are done
          for (const auto& [lo, hi] : spans) {
            for (int l = std::max(lo, next); l <= hi; ++l) {
              const int32_t c = cost[static_cast<size_t>(l)];
              if (c < b) {
                out.push_back(
                    {static_cast<uint16_t>(l), static_cast<uint16_t>(c)});
              }
            }
            next = std::max(next, hi + 1);
          }
          pr.far[static_cast<size_t>(p)] = static_cast<uint16_t>(b);
          pr.near_begin[static_cast<size_t>(p + 1)] =
              static_cast<int64_t>(out.size() - first);
        }
      }
    } catch (...) {
      failed = true;
    }
  });
  if (failed) {
    return absl::ResourceExhaustedError("fusion: out of memory (data term)");
  }
  for (int64_t p = 0; p < n; ++p) {
    pr.near_begin[static_cast<size_t>(p + 1)] +=
        pr.near_begin[static_cast<size_t>(p)];
  }
  pr.near.resize(static_cast<size_t>(pr.near_begin.back()));
  for (int y = 0; y < pr.height; ++y) {
    std::vector<MrfProblem::NearCost>& rn = row_near[static_cast<size_t>(y)];
    std::copy(rn.begin(), rn.end(),
              pr.near.begin() + pr.near_begin[static_cast<size_t>(y) * width]);
    std::vector<MrfProblem::NearCost>().swap(rn);
  }

  // Smoothness weights.
  pr.right.assign(static_cast<size_t>(n), 0);
  pr.down.assign(static_cast<size_t>(n), 0);
  pr.potts = params.smoothness != SmoothnessModel::kQuadratic;
  pr.truncation = pr.potts ? 1 : params.quadratic_truncation;
  cv::Mat edges;
  if (params.edge_weight < 1) {
    cv::Mat guide8 = guide;
    if (guide.depth() == CV_32F) guide.convertTo(guide8, CV_8U, 255.0);
    edges = EdgeMask(guide8);
  }
  // The pair's weight; q is its right / lower pixel.
  auto weight = [&](int a, int b, int64_t q) -> int32_t {
    double g = std::abs(a - b);
    double w = 0;
    switch (params.smoothness) {
      case SmoothnessModel::kPottsLinear:
        if (g < params.static_cue) g = 0;
        w = std::max(params.linear_model_thr - g, 1.0);
        break;
      case SmoothnessModel::kPotts:
        w = params.linear_model_thr;
        break;
      case SmoothnessModel::kPottsStaticCue:
        w = (g <= params.static_cue) ? 2.0 : 1.0;
        break;
      case SmoothnessModel::kQuadratic: {
        const double u = (g / 255.0) * (g / 255.0);
        w = params.linear_model_thr * std::exp(-params.quadratic_c * u);
        break;
      }
    }
    if (!edges.empty() && edges.ptr<uchar>()[q] != 0) w *= params.edge_weight;
    return static_cast<int32_t>(std::lround(params.lambda * w));
  };
  const uchar* img = grey.ptr<uchar>();
  for (int y = 0; y < pr.height; ++y) {
    for (int x = 0; x < pr.width; ++x) {
      const int64_t p = static_cast<int64_t>(y) * pr.width + x;
      if (x + 1 < pr.width) {
        pr.right[static_cast<size_t>(p)] = weight(img[p], img[p + 1], p + 1);
      }
      if (y + 1 < pr.height) {
        pr.down[static_cast<size_t>(p)] =
            weight(img[p], img[p + pr.width], p + pr.width);
      }
    }
  }

  if (params.candidate_labels_only) {
    pr.allowed.assign(static_cast<size_t>(n * num_labels), 0);
    const int r = params.candidate_label_radius;
    for (int64_t p = 0; p < n; ++p) {
      bool any = false;
      for (int k = 0; k < num_k; ++k) {
        const float z = cand[static_cast<size_t>(k)][p];
        if (!IsValidDisparity(z, params.max_disp)) continue;
        any = true;
        const int c = static_cast<int>(std::lround(z));
        for (int l = std::max(0, c - r); l <= std::min(num_labels - 1, c + r);
             ++l) {
          pr.allowed[static_cast<size_t>(l * n + p)] = 1;
        }
      }
      if (!any) {
        for (int l = 0; l < num_labels; ++l) {
          pr.allowed[static_cast<size_t>(l * n + p)] = 1;
        }
      }
    }
  }
  return pr;
}

absl::Status CheckProblem(const MrfProblem& pr) {
  const int64_t n = static_cast<int64_t>(pr.width) * pr.height;
  if (pr.width < 1 || pr.height < 1 || pr.num_labels < 1) {
    return absl::InvalidArgumentError("fusion: empty MRF problem");
  }
  if ((pr.near_begin.empty() || !pr.data.empty()) &&
      static_cast<int64_t>(pr.data.size()) != n * pr.num_labels) {
    return absl::InvalidArgumentError(
        "fusion: the data term needs num_labels costs per pixel, or the "
        "sparse view");
  }
  if (static_cast<int64_t>(pr.right.size()) != n ||
      static_cast<int64_t>(pr.down.size()) != n ||
      (!pr.allowed.empty() &&
       static_cast<int64_t>(pr.allowed.size()) != n * pr.num_labels)) {
    return absl::InvalidArgumentError("fusion: inconsistent MRF problem sizes");
  }
  for (int64_t p = 0; p < n; ++p) {
    if (pr.right[static_cast<size_t>(p)] < 0 ||
        pr.down[static_cast<size_t>(p)] < 0) {
      return absl::InvalidArgumentError("fusion: negative smoothness weight");
    }
  }
  if (!pr.potts && (pr.truncation < 1 || pr.truncation > (1 << 16))) {
    return absl::InvalidArgumentError(
        "fusion: truncation must be in [1, 65536]");
  }
  if (!pr.near_begin.empty()) {
    // The sparse view: shape, label range and order, costs below far. (That
    // it matches `data`, when both are given, is the builder's promise;
    // checking it would read the whole volume.)
    if (static_cast<int64_t>(pr.far.size()) != n ||
        static_cast<int64_t>(pr.near_begin.size()) != n + 1 ||
        pr.near_begin.front() != 0 ||
        pr.near_begin.back() != static_cast<int64_t>(pr.near.size())) {
      return absl::InvalidArgumentError("fusion: malformed sparse data view");
    }
    for (int64_t p = 0; p < n; ++p) {
      const int64_t b = pr.near_begin[static_cast<size_t>(p)];
      const int64_t e = pr.near_begin[static_cast<size_t>(p + 1)];
      if (e < b) {
        return absl::InvalidArgumentError("fusion: malformed sparse data view");
      }
      int prev = -1;
      for (int64_t i = b; i < e; ++i) {
        const MrfProblem::NearCost& c = pr.near[static_cast<size_t>(i)];
        if (c.label <= prev || c.label >= pr.num_labels ||
            c.cost >= pr.far[static_cast<size_t>(p)]) {
          return absl::InvalidArgumentError(
              "fusion: malformed sparse data view");
        }
        prev = c.label;
      }
    }
  }
  // Keeps every unary sum and edge capacity of a move inside int.
  const int64_t rho_max = pr.potts ? 1 : pr.truncation;
  for (int64_t p = 0; p < n; ++p) {
    const int64_t w = std::max(pr.right[static_cast<size_t>(p)],
                               pr.down[static_cast<size_t>(p)]);
    if (w * rho_max > (int64_t{1} << 26)) {
      return absl::InvalidArgumentError(
          "fusion: smoothness weight x rho cap exceeds 2^26");
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<MrfProblem> BuildProblem(
    const std::vector<cv::Mat>& candidates, const cv::Mat& guide,
    const FusionOptions& params, const std::vector<cv::Mat>& confidences) {
  try {
    return BuildProblemImpl(candidates, guide, params, confidences);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("fusion: OpenCV: ", e.what()));
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError("fusion: out of memory");
  }
}

namespace {

// D_p(l), from the dense volume or the sparse view.
int32_t DataCost(const MrfProblem& pr, int64_t p, int32_t l) {
  if (!pr.data.empty()) {
    return pr.data[static_cast<size_t>(
        static_cast<int64_t>(l) * pr.width * pr.height + p)];
  }
  for (int64_t i = pr.near_begin[static_cast<size_t>(p)];
       i < pr.near_begin[static_cast<size_t>(p + 1)]; ++i) {
    if (pr.near[static_cast<size_t>(i)].label == l) {
      return pr.near[static_cast<size_t>(i)].cost;
    }
  }
  return pr.far[static_cast<size_t>(p)];
}

}  // namespace

int64_t Energy(const MrfProblem& pr, const std::vector<int32_t>& labels) {
  const int64_t n = static_cast<int64_t>(pr.width) * pr.height;
  int64_t e = 0;
  for (int64_t p = 0; p < n; ++p) {
    const int32_t l = labels[static_cast<size_t>(p)];
    e += DataCost(pr, p, l);
    const int x = static_cast<int>(p % pr.width);
    if (x + 1 < pr.width) {
      e += static_cast<int64_t>(pr.right[static_cast<size_t>(p)]) *
           Rho(pr, l, labels[static_cast<size_t>(p + 1)]);
    }
    if (p + pr.width < n) {
      e += static_cast<int64_t>(pr.down[static_cast<size_t>(p)]) *
           Rho(pr, l, labels[static_cast<size_t>(p + pr.width)]);
    }
  }
  return e;
}

std::vector<int32_t> WinnerTakesAll(const MrfProblem& pr) {
  const int64_t n = static_cast<int64_t>(pr.width) * pr.height;
  std::vector<int32_t> labels(static_cast<size_t>(n), 0);
  if (!pr.near_begin.empty()) {
    // Every label outside the sparse view costs far[p], more than any in it:
    // the first (allowed) minimum is the view's, else the first allowed
    // label.
    auto allowed = [&](int64_t p, int l) {
      return pr.allowed.empty() ||
             pr.allowed[static_cast<size_t>(static_cast<int64_t>(l) * n + p)] !=
                 0;
    };
    for (int64_t p = 0; p < n; ++p) {
      uint16_t best = pr.far[static_cast<size_t>(p)];
      int32_t label = -1;
      for (int64_t i = pr.near_begin[static_cast<size_t>(p)];
           i < pr.near_begin[static_cast<size_t>(p + 1)]; ++i) {
        const MrfProblem::NearCost& c = pr.near[static_cast<size_t>(i)];
        if (c.cost < best && allowed(p, c.label)) {
          best = c.cost;
          label = c.label;
        }
      }
      for (int l = 0; label < 0 && l < pr.num_labels; ++l) {
        if (allowed(p, l)) label = l;
      }
      labels[static_cast<size_t>(p)] = std::max(label, 0);
    }
    return labels;
  }
  std::vector<int32_t> best(static_cast<size_t>(n),
                            std::numeric_limits<int32_t>::max());
  for (int l = 0; l < pr.num_labels; ++l) {
    const uint16_t* row = pr.data.data() + static_cast<int64_t>(l) * n;
    const uint8_t* ok =
        pr.allowed.empty() ? nullptr : pr.allowed.data() + l * n;
    for (int64_t p = 0; p < n; ++p) {
      if (ok != nullptr && ok[p] == 0) continue;
      if (row[p] < best[static_cast<size_t>(p)]) {
        best[static_cast<size_t>(p)] = row[p];
        labels[static_cast<size_t>(p)] = l;
      }
    }
  }
  return labels;
}

namespace {

template <bool kPotts>
inline int32_t RhoOf(const MrfProblem& pr, int32_t a, int32_t b) {
  if constexpr (kPotts) {
    return a != b ? 1 : 0;
  } else {
    return Rho(pr, a, b);
  }
}

// The sparse view of the data term (MrfProblem::near), the problem's own or
// derived from `data` when the problem has none.
struct SparseView {
  const uint16_t* far = nullptr;
  const int64_t* begin = nullptr;
  const MrfProblem::NearCost* near = nullptr;
  std::vector<uint16_t> far_store;
  std::vector<int64_t> begin_store;
  std::vector<MrfProblem::NearCost> near_store;
};

void MakeSparseView(const MrfProblem& pr, SparseView* v) {
  if (!pr.near_begin.empty()) {
    v->far = pr.far.data();
    v->begin = pr.near_begin.data();
    v->near = pr.near.data();
    return;
  }
  const size_t nz = static_cast<size_t>(pr.width) * pr.height;
  v->far_store.assign(nz, 0);
  for (int l = 0; l < pr.num_labels; ++l) {
    const uint16_t* row = pr.data.data() + static_cast<size_t>(l) * nz;
    for (size_t p = 0; p < nz; ++p) {
      v->far_store[p] = std::max(v->far_store[p], row[p]);
    }
  }
  v->begin_store.assign(nz + 1, 0);
  for (int l = 0; l < pr.num_labels; ++l) {
    const uint16_t* row = pr.data.data() + static_cast<size_t>(l) * nz;
    for (size_t p = 0; p < nz; ++p) {
      v->begin_store[p + 1] += row[p] < v->far_store[p] ? 1 : 0;
    }
  }
  for (size_t p = 0; p < nz; ++p) v->begin_store[p + 1] += v->begin_store[p];
  v->near_store.resize(static_cast<size_t>(v->begin_store[nz]));
  std::vector<int64_t> fill(v->begin_store.begin(), v->begin_store.end() - 1);
  for (int l = 0; l < pr.num_labels; ++l) {
    const uint16_t* row = pr.data.data() + static_cast<size_t>(l) * nz;
    for (size_t p = 0; p < nz; ++p) {
      if (row[p] < v->far_store[p]) {
        v->near_store[static_cast<size_t>(fill[p]++)] = {
            static_cast<uint16_t>(l), row[p]};
      }
    }
  }
  v->far = v->far_store.data();
  v->begin = v->begin_store.data();
  v->near = v->near_store.data();
}

// Everything the expansion loop reads of a pixel, in half a cache line: a
// list entry or a neighbour costs one access. right / down are the weights
// of the edges to p + 1 and p + width (0 at the border), so p's left and up
// weights are its neighbours' right and down. The state array has one row
// of sentinels (label -1, weights 0) above and below the image, so the
// inner loops need neither coordinates nor bounds checks.
struct alignas(32) PixelState {
  int32_t label = -1;
  int32_t cur = 0;    // D_p(label)
  int32_t bound = 0;  // largest smoothness saving of a switch
  int32_t stamp = 0;  // tick of the last change of p or of a neighbour
  int32_t node = -1;  // graph node in the current expansion, or -1
  int32_t right = 0;
  int32_t down = 0;
  int32_t next = 0;  // see Lists
};

struct Entry {
  int32_t p;
  int32_t d;  // D_p(alpha)
};

// Per-label lists of the pixels that may switch to the label (Potts and
// quadratic alike). A pixel can only switch to alpha when D_p(alpha) -
// D_p(f_p) <= bound_p, so pixel p is listed for every label with D_p(l) <=
// reach_p, where reach_p >= D_p(f_p) + bound_p always: it starts at that
// value and is raised (p listed for the new labels) whenever p switches to a
// costlier label. The labels at the pixel's constant far_p are not listed
// one by one: once reach_p >= far_p the pixel goes to `everywhere`, scanned
// in every expansion with cost far_p; its sparse-view labels stay listed
// with their own costs and are scanned first (a second sighting of a pixel
// is then either skipped or, costing more, dominated too). Entries carry
// D_p(l), so a scan reads the list and the pixel's state only. The state
// keeps next_p, the smallest cost above reach_p (far_p included; the
// largest int once everywhere): a raise below it lists nothing new and
// does not read the sparse view.
class Lists {
 public:
  Lists(const MrfProblem& pr, const SparseView& v)
      : pr_(pr), v_(v), by_label_(static_cast<size_t>(pr.num_labels)) {}

  // Lists pixel p (state s, with cur and bound set), pixels in ascending
  // order.
  void Init(int p, PixelState& s) {
    s.next = 0;
    List(p, s, s.cur + s.bound);
  }

  const std::vector<Entry>& ForLabel(int l) const {
    return by_label_[static_cast<size_t>(l)];
  }
  const std::vector<int>& Everywhere() const { return everywhere_; }
  int32_t Far(int p) const { return v_.far[static_cast<size_t>(p)]; }

  // p (state s) now costs s.cur: list it where it can now go.
  void Raise(int p, PixelState& s) {
    const int32_t reach = s.cur + s.bound;
    if (reach >= s.next) List(p, s, reach);
  }

 private:
  // Lists p for the labels costing from s.next to reach; s.next := the
  // smallest cost above reach.
  void List(int p, PixelState& s, int32_t reach) {
    const size_t pz = static_cast<size_t>(p);
    const int32_t far = v_.far[pz];
    int32_t next = std::numeric_limits<int32_t>::max();
    if (far <= reach) {
      everywhere_.push_back(p);
    } else {
      next = far;
    }
    for (int64_t i = v_.begin[pz]; i < v_.begin[pz + 1]; ++i) {
      const MrfProblem::NearCost& e = v_.near[i];
      if (e.cost > reach) {
        next = std::min<int32_t>(next, e.cost);
      } else if (e.cost >= s.next) {
        Add(e.label, p, e.cost);
      }
    }
    s.next = next;
  }

  void Add(int l, int p, int32_t d) {
    if (!pr_.allowed.empty() &&
        pr_.allowed[static_cast<size_t>(l) * pr_.width * pr_.height +
                    static_cast<size_t>(p)] == 0) {
      return;
    }
    by_label_[static_cast<size_t>(l)].push_back({p, d});
  }

  const MrfProblem& pr_;
  const SparseView& v_;
  std::vector<std::vector<Entry>> by_label_;
  std::vector<int> everywhere_;
};

template <bool kPotts>
SolverStats Expand(const MrfProblem& pr, std::vector<int32_t>& labels,
                   int max_cycles, bool prune, Clock::time_point t_start) {
  const int n = pr.width * pr.height;
  const int w = pr.width;
  const size_t nz = static_cast<size_t>(n);
  SolverStats stats;
  SparseView view;
  MakeSparseView(pr, &view);
  std::vector<PixelState> state(nz + 2 * static_cast<size_t>(w));
  PixelState* const st = state.data() + w;
  const int32_t rho_max = RhoMax(pr);
  // Without pruning every pixel is scanned in every expansion: no lists, but
  // the dense volume.
  std::optional<Lists> lists;
  if (prune) lists.emplace(pr, view);
  int64_t energy = 0;
  for (int p = 0; p < n; ++p) {
    const size_t pz = static_cast<size_t>(p);
    PixelState& s = st[p];
    s.label = labels[pz];
    if ((p + 1) % w != 0) s.right = pr.right[pz];
    if (p + w < n) s.down = pr.down[pz];
    s.bound = (st[p - 1].right + s.right + st[p - w].down + s.down) * rho_max;
    s.cur = view.far[pz];
    for (int64_t i = view.begin[pz]; i < view.begin[pz + 1]; ++i) {
      if (view.near[i].label == s.label) s.cur = view.near[i].cost;
    }
    energy += s.cur;
    if (s.right != 0) {
      energy += static_cast<int64_t>(s.right) *
                RhoOf<kPotts>(pr, s.label, labels[pz + 1]);
    }
    if (s.down != 0) {
      energy += static_cast<int64_t>(s.down) *
                RhoOf<kPotts>(pr, s.label, labels[pz + static_cast<size_t>(w)]);
    }
    if (lists) lists->Init(p, s);
  }
  std::vector<uint16_t> dense_store;
  const uint16_t* dense = pr.data.data();
  if (!prune && pr.data.empty()) {
    dense_store.resize(nz * static_cast<size_t>(pr.num_labels));
    for (int l = 0; l < pr.num_labels; ++l) {
      std::copy_n(view.far, nz,
                  dense_store.begin() +
                      static_cast<std::ptrdiff_t>(static_cast<size_t>(l) * nz));
    }
    for (size_t p = 0; p < nz; ++p) {
      for (int64_t i = view.begin[p]; i < view.begin[p + 1]; ++i) {
        dense_store[static_cast<size_t>(view.near[i].label) * nz + p] =
            view.near[i].cost;
      }
    }
    dense = dense_store.data();
  }
  stats.index_seconds = Seconds(t_start, Clock::now());

  std::vector<Entry> free_px;
  free_px.reserve(nz);
  // Per graph node: terminal weights from edges added before it (below).
  std::vector<int32_t> unary(nz);
  std::vector<int> changed;
  changed.reserve(nz);
  // Expansion skipping (Potts, with pruning): an expansion on alpha from a
  // labelling that is optimal among its own alpha-expansions cannot lower
  // the energy, and after alpha's last expansion the labelling is. A later
  // move changes the energy of alpha's moves only through pixels that may
  // switch to alpha (all listed) or their neighbours; when none of the
  // listed pixels has a stamp after alpha's last expansion, the expansion
  // would be rejected, so it is skipped. Needs exact cuts: not for the
  // truncated quadratic moves.
  const bool skip = kPotts && prune;
  std::vector<int32_t> last_run(static_cast<size_t>(pr.num_labels), -1);
  int32_t tick = 0;
  Graph graph(n, 2 * n, &MaxflowError);

  stats.energy_before = energy;
  for (int cycle = 0; cycle < max_cycles; ++cycle) {
    ++stats.cycles;
    bool improved = false;
    for (int32_t alpha = 0; alpha < pr.num_labels; ++alpha) {
      const int32_t since = last_run[static_cast<size_t>(alpha)];
      const uint8_t* ok =
          pr.allowed.empty()
              ? nullptr
              : pr.allowed.data() + static_cast<size_t>(alpha) * nz;
      bool dirty = !skip;
      free_px.clear();
      // A pixel may be listed twice (in `everywhere` too): node >= 0 marks
      // the first.
      auto consider = [&](int p, int32_t d) {
        PixelState& s = st[p];
        dirty |= s.stamp > since;
        if (s.label == alpha || s.node >= 0) return;
        if (prune && d - s.cur > s.bound) {
          return;  // dominated: stays in every optimal move
        }
        s.node = static_cast<int>(free_px.size());
        free_px.push_back({p, d});
      };
      if (prune) {
        for (const Entry& e : lists->ForLabel(alpha)) consider(e.p, e.d);
        for (int p : lists->Everywhere()) {
          if (ok == nullptr || ok[p] != 0) consider(p, lists->Far(p));
        }
      } else {
        const uint16_t* da = dense + static_cast<size_t>(alpha) * nz;
        for (int p = 0; p < n; ++p) {
          if (ok == nullptr || ok[p] != 0) consider(p, da[p]);
        }
      }
      if constexpr (kPotts) {
        if (prune) {
          // Potts: an edge saves w_pq only if q ends at alpha, i.e. q is at
          // alpha or may switch (still listed). A pixel whose data increase
          // exceeds those edges' weights is dominated too; dropping it keeps
          // the list a superset of the switchers, so one in-place pass is
          // exact.
          auto at_alpha = [&](const PixelState& q) {
            return q.label == alpha || q.node >= 0;
          };
          size_t kept = 0;
          for (const Entry& f : free_px) {
            PixelState* s = st + f.p;
            const int32_t excess = f.d - s->cur;
            if (excess > 0) {
              int32_t saving = 0;
              if (s[-1].right != 0 && at_alpha(s[-1])) saving += s[-1].right;
              if (s->right != 0 && at_alpha(s[1])) saving += s->right;
              if (s[-w].down != 0 && at_alpha(s[-w])) saving += s[-w].down;
              if (s->down != 0 && at_alpha(s[w])) saving += s->down;
              if (excess > saving) {
                s->node = -1;
                continue;
              }
            }
            free_px[kept++] = f;
          }
          free_px.resize(kept);
          for (size_t i = 0; i < kept; ++i) {
            st[free_px[i].p].node = static_cast<int>(i);
          }
        }
      }
      if (free_px.empty() || !dirty) {
        for (const Entry& f : free_px) st[f.p].node = -1;
        if (!free_px.empty()) ++stats.skipped;
        continue;
      }
      const int m = static_cast<int>(free_px.size());
      graph.reset();
      graph.add_node(m);
      // unary[i]: what node i's terminal weights get from edges added before
      // it is reached (a node reached already gets them directly).
      std::fill_n(unary.begin(), m, 0);
      for (int i = 0; i < m; ++i) {
        const Entry& f = free_px[static_cast<size_t>(i)];
        const PixelState* s = st + f.p;
        const int32_t fp = s->label;
        // E(alpha) - E(keep) of this node's unary terms.
        int32_t d = f.d - s->cur + unary[static_cast<size_t>(i)];
        // Each edge between two nodes is added once, from its lower pixel.
        auto edge = [&](const PixelState& q, int32_t wpq, bool forward) {
          if (wpq == 0) return;
          const int32_t fq = q.label;
          if (q.node < 0) {
            d += wpq *
                 (RhoOf<kPotts>(pr, alpha, fq) - RhoOf<kPotts>(pr, fp, fq));
          } else if (forward) {
            const int32_t a = wpq * RhoOf<kPotts>(pr, fp, fq);
            const int32_t b = wpq * RhoOf<kPotts>(pr, fp, alpha);
            const int32_t c = wpq * RhoOf<kPotts>(pr, alpha, fq);
            // E = A + (C - A) x_p + (D - C) x_q + (B + C - A - D)(1-x_p)x_q,
            // D = 0.
            d += c - a;
            if (q.node > i) {
              unary[static_cast<size_t>(q.node)] -= c;
            } else {
              graph.add_tweights(q.node, 0, c);
            }
            const int32_t cap = std::max(b + c - a, 0);
            if (cap > 0) graph.add_edge(i, q.node, cap, 0);
          }
        };
        edge(s[1], s->right, true);
        edge(s[-1], s[-1].right, false);
        edge(s[w], s->down, true);
        edge(s[-w], s[-w].down, false);
        // x = 1 (switch to alpha) <=> SINK; cap_source is paid in SINK.
        if (d > 0) {
          graph.add_tweights(i, d, 0);
        } else {
          graph.add_tweights(i, 0, -d);
        }
      }
      const Clock::time_point t1 = Clock::now();
      graph.maxflow();
      stats.maxflow_seconds += Seconds(t1, Clock::now());
      ++stats.expansions;
      stats.graph_nodes += m;

      // Switching pixels: node = -2 (tells "moves too" apart in the energy
      // change below), the others' node back to -1.
      changed.clear();
      for (int i = 0; i < m; ++i) {
        const bool moves = graph.what_segment(i) == Graph::SINK;
        st[free_px[static_cast<size_t>(i)].p].node = moves ? -2 : -1;
        if (moves) changed.push_back(i);
      }
      // Exact energy change of the move.
      int64_t delta = 0;
      for (int i : changed) {
        const Entry& f = free_px[static_cast<size_t>(i)];
        const PixelState* s = st + f.p;
        delta += static_cast<int64_t>(f.d) - s->cur;
        const int32_t fp = s->label;
        // Each edge between two switching pixels is counted from its lower
        // pixel.
        auto pair = [&](const PixelState& q, int32_t wpq, bool forward) {
          if (wpq == 0) return;
          const bool q_moves = q.node == -2;
          if (q_moves && !forward) return;
          const int32_t fq_new = q_moves ? alpha : q.label;
          delta +=
              static_cast<int64_t>(wpq) * (RhoOf<kPotts>(pr, alpha, fq_new) -
                                           RhoOf<kPotts>(pr, fp, q.label));
        };
        pair(s[1], s->right, true);
        pair(s[-1], s[-1].right, false);
        pair(s[w], s->down, true);
        pair(s[-w], s[-w].down, false);
      }
      if (delta < 0) {
        ++tick;
        for (int i : changed) {
          const Entry& f = free_px[static_cast<size_t>(i)];
          PixelState* s = st + f.p;
          s->label = alpha;
          s->cur = f.d;
          if (lists) lists->Raise(f.p, *s);
          s->stamp = tick;
          if (s->right != 0) s[1].stamp = tick;
          if (s[-1].right != 0) s[-1].stamp = tick;
          if (s->down != 0) s[w].stamp = tick;
          if (s[-w].down != 0) s[-w].stamp = tick;
        }
        energy += delta;
        improved = true;
        ++stats.accepted;
      }
      last_run[static_cast<size_t>(alpha)] = tick;
      for (int i : changed) st[free_px[static_cast<size_t>(i)].p].node = -1;
    }
    if (!improved) break;
  }
  for (int p = 0; p < n; ++p) labels[static_cast<size_t>(p)] = st[p].label;
  stats.energy_after = energy;
  stats.total_seconds = Seconds(t_start, Clock::now());
  stats.build_seconds = stats.total_seconds - stats.maxflow_seconds;
  return stats;
}

}  // namespace

absl::StatusOr<SolverStats> AlphaExpansion(const MrfProblem& pr,
                                           std::vector<int32_t>* labels_ptr,
                                           int max_cycles,
                                           bool prune_dominated) {
  const Clock::time_point t_start = Clock::now();
  RETURN_IF_ERROR(CheckProblem(pr));
  const int64_t n64 = static_cast<int64_t>(pr.width) * pr.height;
  if (labels_ptr == nullptr ||
      static_cast<int64_t>(labels_ptr->size()) != n64) {
    return absl::InvalidArgumentError(
        "fusion: the labelling must have one label per pixel");
  }
  if (n64 > std::numeric_limits<int>::max() / 4) {
    return absl::InvalidArgumentError("fusion: image too large");
  }
  for (int32_t l : *labels_ptr) {
    if (l < 0 || l >= pr.num_labels) {
      return absl::InvalidArgumentError(absl::StrCat(
          "fusion: initial label ", l, " out of [0, ", pr.num_labels, ")"));
    }
  }
  try {
    return pr.potts ? Expand<true>(pr, *labels_ptr, max_cycles, prune_dominated,
                                   t_start)
                    : Expand<false>(pr, *labels_ptr, max_cycles,
                                    prune_dominated, t_start);
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError("fusion: out of memory in max-flow");
  }
}

absl::Status CheckCandidateMaps(const std::vector<cv::Mat>& candidates) {
  if (candidates.empty()) {
    return absl::InvalidArgumentError("fusion: no candidate disparity maps");
  }
  const cv::Size size = candidates[0].size();
  for (size_t k = 0; k < candidates.size(); ++k) {
    const cv::Mat& c = candidates[k];
    if (c.empty() || c.type() != CV_32FC1) {
      return absl::InvalidArgumentError(absl::StrCat(
          "fusion: candidate ", k, " must be a non-empty CV_32FC1 map"));
    }
    if (c.size() != size) {
      return absl::InvalidArgumentError(
          absl::StrCat("fusion: candidate ", k, " is ", c.cols, "x", c.rows,
                       ", candidate 0 is ", size.width, "x", size.height));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<FusionResult> FuseAlphaExpansion(
    const std::vector<cv::Mat>& candidates, const cv::Mat& guide,
    const FusionOptions& params, const std::vector<cv::Mat>& confidences) {
  const Clock::time_point t0 = Clock::now();
  ASSIGN_OR_RETURN(MrfProblem pr,
                   BuildProblem(candidates, guide, params, confidences));
  std::vector<int32_t> labels = WinnerTakesAll(pr);
  const double setup = Seconds(t0, Clock::now());
  ASSIGN_OR_RETURN(
      SolverStats stats,
      AlphaExpansion(pr, &labels, params.max_cycles, params.prune_dominated));
  FusionResult result;
  result.stats = stats;
  result.stats.setup_seconds = setup;
  result.disparity.create(pr.height, pr.width, CV_32FC1);
  float* out = result.disparity.ptr<float>();
  for (size_t p = 0; p < labels.size(); ++p) {
    out[p] = static_cast<float>(labels[p]);
  }
  return result;
}

namespace {

template <typename Reduce>
absl::StatusOr<cv::Mat> FuseReduce(const std::vector<cv::Mat>& candidates,
                                   int max_disp, Reduce reduce) {
  RETURN_IF_ERROR(CheckCandidates(candidates, max_disp));
  const cv::Size size = candidates[0].size();
  cv::Mat out(size, CV_32FC1);
  std::vector<float> values;
  values.reserve(candidates.size());
  for (int y = 0; y < size.height; ++y) {
    float* o = out.ptr<float>(y);
    for (int x = 0; x < size.width; ++x) {
      values.clear();
      for (const cv::Mat& c : candidates) {
        const float z = c.ptr<float>(y)[x];
        if (IsValidDisparity(z, max_disp)) values.push_back(z);
      }
      o[x] = values.empty() ? std::numeric_limits<float>::quiet_NaN()
                            : reduce(values);
    }
  }
  return out;
}

}  // namespace

absl::StatusOr<cv::Mat> FuseMean(const std::vector<cv::Mat>& candidates,
                                 int max_disp) {
  return FuseReduce(candidates, max_disp, [](std::vector<float>& v) {
    double s = 0;
    for (float z : v) s += z;
    return static_cast<float>(s / static_cast<double>(v.size()));
  });
}

absl::StatusOr<cv::Mat> FuseMedian(const std::vector<cv::Mat>& candidates,
                                   int max_disp) {
  return FuseReduce(candidates, max_disp, [](std::vector<float>& v) {
    std::sort(v.begin(), v.end());
    const size_t h = v.size() / 2;
    return v.size() % 2 == 1 ? v[h] : 0.5f * (v[h - 1] + v[h]);
  });
}

}  // namespace hdrstereo::fusion
