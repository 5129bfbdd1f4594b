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
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"

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

bool Valid(float z, int max_disp) {
  return std::isfinite(z) && z >= 0.0f &&
         z <= static_cast<float>(max_disp) + 0.5f;
}

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
  if (candidates.empty()) {
    return absl::InvalidArgumentError("fusion: no candidate disparity maps");
  }
  if (max_disp < 1 || max_disp > 4096) {
    return absl::InvalidArgumentError(
        absl::StrCat("fusion: max_disp must be in [1, 4096], got ", max_disp));
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
double UnitCost(const FusionParams& params, double d) {
  if (params.data == DataModel::kGaussian) {
    return 1.0 - std::exp(-d * d / (2.0 * params.sigma * params.sigma));
  }
  return std::min(d * d, params.data_truncation);
}

double UnitCostMax(const FusionParams& params) {
  return params.data == DataModel::kGaussian ? 1.0 : params.data_truncation;
}

absl::StatusOr<MrfProblem> BuildProblemImpl(
    const std::vector<cv::Mat>& candidates, const cv::Mat& guide,
    const FusionParams& params, const std::vector<cv::Mat>& confidences) {
  if (absl::Status s = CheckCandidates(candidates, params.max_disp); !s.ok()) {
    return s;
  }
  if (!(params.sigma > 0) || !(params.data_scale > 0) ||
      !(params.lambda >= 0) || !(params.lambda <= 1e4) ||
      !(params.linear_model_thr <= 1e4) || !(params.data_truncation > 0) ||
      params.quadratic_truncation < 1 || !(params.linear_model_thr >= 1) ||
      params.candidate_label_radius < 0) {
    return absl::InvalidArgumentError(
        "fusion: sigma, data_scale, data_truncation must be > 0, lambda in "
        "[0, 1e4], linear_model_thr in [1, 1e4], quadratic_truncation >= 1, "
        "candidate_label_radius >= 0");
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
  absl::StatusOr<cv::Mat> grey = GuideGrey8(guide, size);
  if (!grey.ok()) return grey.status();

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
  pr.data.resize(static_cast<size_t>(n * num_labels));
  // Row by row into a small label x width buffer (cache friendly), then
  // copied into the label-major volume; rows in parallel.
  const int width = pr.width;
  std::atomic<bool> failed{false};
  cv::parallel_for_(cv::Range(0, pr.height), [&](const cv::Range& rows) {
    try {
      std::vector<int32_t> buf(static_cast<size_t>(num_labels) *
                               static_cast<size_t>(width));
      std::vector<int32_t> base(static_cast<size_t>(width));
      for (int y = rows.start; y < rows.end; ++y) {
        const int64_t row0 = static_cast<int64_t>(y) * width;
        for (int x = 0; x < width; ++x) {
          int32_t b = 0;
          for (int k = 0; k < num_k; ++k) {
            if (!Valid(cand[static_cast<size_t>(k)][row0 + x],
                       params.max_disp)) {
              continue;
            }
            b += Round(params.data_scale * confidence(k, row0 + x) * cost_max);
          }
          base[static_cast<size_t>(x)] = b;
        }
        for (int l = 0; l < num_labels; ++l) {
          std::copy(base.begin(), base.end(),
                    buf.begin() + static_cast<int64_t>(l) * width);
        }
        for (int x = 0; x < width; ++x) {
          for (int k = 0; k < num_k; ++k) {
            const float z = cand[static_cast<size_t>(k)][row0 + x];
            if (!Valid(z, params.max_disp)) continue;
            const int centre = static_cast<int>(z + 0.5f);
            const int lo = std::max(0, centre - window - 1);
            const int hi = std::min(num_labels - 1, centre + window + 1);
            int32_t* cell = buf.data() + x;
            if (confidences.empty()) {
              for (int l = lo; l <= hi; ++l) {
                const size_t i = std::min(
                    static_cast<size_t>(
                        std::abs(static_cast<float>(l) - z) * kLutStep + 0.5f),
                    saving.size() - 1);
                cell[static_cast<int64_t>(l) * width] -= saving[i];
              }
            } else {
              const double scale = params.data_scale * confidence(k, row0 + x);
              const int32_t full = Round(scale * cost_max);
              for (int l = lo; l <= hi; ++l) {
                const size_t i = std::min(
                    static_cast<size_t>(
                        std::abs(static_cast<float>(l) - z) * kLutStep + 0.5f),
                    lut.size() - 1);
                cell[static_cast<int64_t>(l) * width] -=
                    full - Round(scale * lut[i]);
              }
            }
          }
        }
        for (int l = 0; l < num_labels; ++l) {
          uint16_t* dst = pr.data.data() + static_cast<int64_t>(l) * n + row0;
          const int32_t* src = buf.data() + static_cast<int64_t>(l) * width;
          for (int x = 0; x < width; ++x) {
            dst[x] = static_cast<uint16_t>(src[x]);
          }
        }
      }
    } catch (...) {
      failed = true;
    }
  });
  if (failed) {
    return absl::ResourceExhaustedError("fusion: out of memory (data term)");
  }

  // Smoothness weights.
  pr.right.assign(static_cast<size_t>(n), 0);
  pr.down.assign(static_cast<size_t>(n), 0);
  pr.potts = params.smoothness != SmoothnessModel::kQuadratic;
  pr.truncation = pr.potts ? 1 : params.quadratic_truncation;
  auto weight = [&](int a, int b) -> int32_t {
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
    return static_cast<int32_t>(std::lround(params.lambda * w));
  };
  const uchar* img = grey->ptr<uchar>();
  for (int y = 0; y < pr.height; ++y) {
    for (int x = 0; x < pr.width; ++x) {
      const int64_t p = static_cast<int64_t>(y) * pr.width + x;
      if (x + 1 < pr.width) {
        pr.right[static_cast<size_t>(p)] = weight(img[p], img[p + 1]);
      }
      if (y + 1 < pr.height) {
        pr.down[static_cast<size_t>(p)] = weight(img[p], img[p + pr.width]);
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
        if (!Valid(z, params.max_disp)) continue;
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
  if (static_cast<int64_t>(pr.data.size()) != n * pr.num_labels ||
      static_cast<int64_t>(pr.right.size()) != n ||
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
    const FusionParams& params, const std::vector<cv::Mat>& confidences) {
  try {
    return BuildProblemImpl(candidates, guide, params, confidences);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("fusion: OpenCV: ", e.what()));
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError("fusion: out of memory");
  }
}

int64_t Energy(const MrfProblem& pr, const std::vector<int32_t>& labels) {
  const int64_t n = static_cast<int64_t>(pr.width) * pr.height;
  int64_t e = 0;
  for (int64_t p = 0; p < n; ++p) {
    const int32_t l = labels[static_cast<size_t>(p)];
    e += pr.data[static_cast<size_t>(l * n + p)];
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

// A pixel's four edge weights, 0 where the neighbour is outside the image, so
// the inner loops need neither coordinates nor bounds checks.
struct Neighbours {
  int32_t left = 0, right = 0, up = 0, down = 0;
};

template <bool kPotts>
inline int32_t RhoOf(const MrfProblem& pr, int32_t a, int32_t b) {
  if constexpr (kPotts) {
    return a != b ? 1 : 0;
  } else {
    return Rho(pr, a, b);
  }
}

// For each label, the pixels that may take it in an optimal move, ascending.
// A pixel can only switch to alpha when D_p(alpha) - D_p(f_p) <= bound_p; as
// D_p(f_p) >= min_l D_p(l), the pixels with D_p(alpha) <= min_l D_p(l) +
// bound_p are a static superset. Scanned in blocks whose any-hit test
// vectorises: most blocks of most labels have no such pixel.
std::vector<std::vector<int>> ReachableByLabel(
    const MrfProblem& pr, const std::vector<int32_t>& bound, bool prune) {
  const int n = pr.width * pr.height;
  const size_t nz = static_cast<size_t>(n);
  // Loops in fixed blocks of kBlock pixels (plus a scalar tail) so that -O2
  // vectorises them.
  constexpr int kBlock = 64;
  std::vector<uint16_t> thr(nz, std::numeric_limits<uint16_t>::max());
  if (prune) {
    std::vector<uint16_t> dmin(nz, std::numeric_limits<uint16_t>::max());
    for (int l = 0; l < pr.num_labels; ++l) {
      const uint16_t* row = pr.data.data() + static_cast<size_t>(l) * nz;
      uint16_t* dm = dmin.data();
      size_t p0 = 0;
      for (; p0 + kBlock <= nz; p0 += kBlock) {
        uint16_t block[kBlock];
        for (int j = 0; j < kBlock; ++j) {
          block[j] = std::min(dm[p0 + static_cast<size_t>(j)],
                              row[p0 + static_cast<size_t>(j)]);
        }
        std::copy_n(block, kBlock, dm + p0);
      }
      for (; p0 < nz; ++p0) dm[p0] = std::min(dm[p0], row[p0]);
    }
    for (size_t p = 0; p < nz; ++p) {
      thr[p] = static_cast<uint16_t>(std::min<int32_t>(
          dmin[p] + bound[p], std::numeric_limits<uint16_t>::max()));
    }
  }
  std::vector<std::vector<int>> reach(static_cast<size_t>(pr.num_labels));
  for (int l = 0; l < pr.num_labels; ++l) {
    const uint16_t* row = pr.data.data() + static_cast<size_t>(l) * nz;
    const uint8_t* ok = pr.allowed.empty()
                            ? nullptr
                            : pr.allowed.data() + static_cast<size_t>(l) * nz;
    std::vector<int>& list = reach[static_cast<size_t>(l)];
    auto collect = [&](int p0, int p1) {
      for (int p = p0; p < p1; ++p) {
        if (row[p] <= thr[static_cast<size_t>(p)] &&
            (ok == nullptr || ok[p] != 0)) {
          list.push_back(p);
        }
      }
    };
    int p0 = 0;
    for (; p0 + kBlock <= n; p0 += kBlock) {
      int hit = 0;
      for (int j = 0; j < kBlock; ++j) {
        hit |= row[p0 + j] <= thr[static_cast<size_t>(p0 + j)] ? 1 : 0;
      }
      if (hit != 0) collect(p0, p0 + kBlock);
    }
    collect(p0, n);
  }
  return reach;
}

template <bool kPotts>
SolverStats Expand(const MrfProblem& pr, std::vector<int32_t>& labels,
                   int max_cycles, bool prune) {
  const int n = pr.width * pr.height;
  const int w = pr.width;
  const size_t nz = static_cast<size_t>(n);
  const Clock::time_point t_start = Clock::now();
  SolverStats stats;
  std::vector<Neighbours> nb(nz);
  std::vector<int32_t> cur(nz);
  // Largest saving a pixel can get from its edges by switching.
  std::vector<int32_t> bound(nz);
  const int32_t rho_max = RhoMax(pr);
  for (int p = 0; p < n; ++p) {
    const size_t pz = static_cast<size_t>(p);
    const int x = p % w;
    Neighbours& e = nb[pz];
    if (x > 0) e.left = pr.right[pz - 1];
    if (x + 1 < w) e.right = pr.right[pz];
    if (p >= w) e.up = pr.down[pz - static_cast<size_t>(w)];
    if (p + w < n) e.down = pr.down[pz];
    bound[pz] = (e.left + e.right + e.up + e.down) * rho_max;
    cur[pz] = pr.data[static_cast<size_t>(labels[pz]) * nz + pz];
  }
  const std::vector<std::vector<int>> reach =
      ReachableByLabel(pr, bound, prune);
  stats.index_seconds = Seconds(t_start, Clock::now());
  stats.build_seconds += stats.index_seconds;

  std::vector<int> node(nz, -1);
  std::vector<int> free_px;
  free_px.reserve(nz);
  // Per graph node: the unary difference E(alpha) - E(keep) added by the
  // edges to earlier nodes (nodes are in ascending pixel order, so a node's
  // backward edges are all added before it is reached).
  std::vector<int32_t> from_earlier(nz);
  std::vector<uint8_t> moved(nz, 0);
  std::vector<int> changed;
  changed.reserve(nz);
  // Expansion skipping (Potts, with pruning): an expansion on alpha from a
  // labelling that is optimal among its own alpha-expansions cannot lower
  // the energy, and after alpha's last expansion the labelling is. A later
  // move changes the energy of alpha's moves only through pixels in
  // reach[alpha] or their neighbours; when none has changed (stamp <= the
  // tick of alpha's last expansion), the expansion would be rejected, so it
  // is skipped. Needs exact cuts: not for the truncated quadratic moves.
  const bool skip = kPotts && prune;
  std::vector<int64_t> stamp(nz, 0);
  std::vector<int64_t> last_run(static_cast<size_t>(pr.num_labels), -1);
  int64_t tick = 0;
  Graph graph(n, 2 * n, &MaxflowError);

  int64_t energy = Energy(pr, labels);
  stats.energy_before = energy;
  for (int cycle = 0; cycle < max_cycles; ++cycle) {
    ++stats.cycles;
    bool improved = false;
    for (int32_t alpha = 0; alpha < pr.num_labels; ++alpha) {
      const Clock::time_point t0 = Clock::now();
      const uint16_t* da = pr.data.data() + static_cast<size_t>(alpha) * nz;
      const int64_t since = last_run[static_cast<size_t>(alpha)];
      bool dirty = !skip;
      free_px.clear();
      for (int p : reach[static_cast<size_t>(alpha)]) {
        const size_t pz = static_cast<size_t>(p);
        dirty |= stamp[pz] > since;
        if (labels[pz] == alpha) continue;
        if (prune && da[p] - cur[pz] > bound[pz]) {
          continue;  // dominated: stays in every optimal move
        }
        node[pz] = static_cast<int>(free_px.size());
        free_px.push_back(p);
      }
      if constexpr (kPotts) {
        if (prune) {
          // Potts: an edge saves w_pq only if q ends at alpha, i.e. q is at
          // alpha or may switch (still listed). A pixel whose data increase
          // exceeds those edges' weights is dominated too; dropping it keeps
          // the list a superset of the switchers, so one in-place pass is
          // exact.
          size_t kept = 0;
          for (int p : free_px) {
            const size_t pz = static_cast<size_t>(p);
            const int32_t excess = da[p] - cur[pz];
            if (excess > 0) {
              const Neighbours& e = nb[pz];
              auto at_alpha = [&](int q) {
                const size_t qz = static_cast<size_t>(q);
                return labels[qz] == alpha || node[qz] >= 0;
              };
              int32_t saving = 0;
              if (e.left != 0 && at_alpha(p - 1)) saving += e.left;
              if (e.right != 0 && at_alpha(p + 1)) saving += e.right;
              if (e.up != 0 && at_alpha(p - w)) saving += e.up;
              if (e.down != 0 && at_alpha(p + w)) saving += e.down;
              if (excess > saving) {
                node[pz] = -1;
                continue;
              }
            }
            free_px[kept++] = p;
          }
          free_px.resize(kept);
          for (size_t i = 0; i < kept; ++i) {
            node[static_cast<size_t>(free_px[i])] = static_cast<int>(i);
          }
        }
      }
      if (free_px.empty() || !dirty) {
        for (int p : free_px) node[static_cast<size_t>(p)] = -1;
        if (!free_px.empty()) ++stats.skipped;
        stats.build_seconds += Seconds(t0, Clock::now());
        continue;
      }
      const int m = static_cast<int>(free_px.size());
      graph.reset();
      graph.add_node(m);
      std::fill_n(from_earlier.begin(), m, 0);
      for (int i = 0; i < m; ++i) {
        const int p = free_px[static_cast<size_t>(i)];
        const size_t pz = static_cast<size_t>(p);
        const int32_t fp = labels[pz];
        // E(alpha) - E(keep) of this node's unary terms.
        int32_t d = da[p] - cur[pz] + from_earlier[static_cast<size_t>(i)];
        auto edge = [&](int q, int32_t wpq, bool forward) {
          if (wpq == 0) return;
          const size_t qz = static_cast<size_t>(q);
          const int nq = node[qz];
          const int32_t fq = labels[qz];
          if (nq < 0) {
            d += wpq *
                 (RhoOf<kPotts>(pr, alpha, fq) - RhoOf<kPotts>(pr, fp, fq));
          } else if (forward) {
            const int32_t a = wpq * RhoOf<kPotts>(pr, fp, fq);
            const int32_t b = wpq * RhoOf<kPotts>(pr, fp, alpha);
            const int32_t c = wpq * RhoOf<kPotts>(pr, alpha, fq);
            // E = A + (C - A) x_p + (D - C) x_q + (B + C - A - D)(1-x_p)x_q,
            // D = 0.
            d += c - a;
            from_earlier[static_cast<size_t>(nq)] -= c;
            const int32_t cap = std::max(b + c - a, 0);
            if (cap > 0) graph.add_edge(i, nq, cap, 0);
          }
        };
        const Neighbours& e = nb[pz];
        edge(p + 1, e.right, true);
        edge(p - 1, e.left, false);
        edge(p + w, e.down, true);
        edge(p - w, e.up, false);
        // x = 1 (switch to alpha) <=> SINK; cap_source is paid in SINK.
        if (d > 0) {
          graph.add_tweights(i, d, 0);
        } else {
          graph.add_tweights(i, 0, -d);
        }
      }
      const Clock::time_point t1 = Clock::now();
      graph.maxflow();
      const Clock::time_point t2 = Clock::now();
      stats.build_seconds += Seconds(t0, t1);
      stats.maxflow_seconds += Seconds(t1, t2);
      ++stats.expansions;
      stats.graph_nodes += m;

      changed.clear();
      for (int i = 0; i < m; ++i) {
        if (graph.what_segment(i) == Graph::SINK) {
          const int p = free_px[static_cast<size_t>(i)];
          changed.push_back(p);
          moved[static_cast<size_t>(p)] = 1;
        }
      }
      // Exact energy change of the move.
      int64_t delta = 0;
      for (int p : changed) {
        const size_t pz = static_cast<size_t>(p);
        delta += static_cast<int64_t>(da[p]) - cur[pz];
        const int32_t fp = labels[pz];
        auto pair = [&](int q, int32_t wpq) {
          if (wpq == 0) return;
          const size_t qz = static_cast<size_t>(q);
          if (moved[qz] && q < p) return;  // counted from q
          const int32_t fq_new = moved[qz] ? alpha : labels[qz];
          delta +=
              static_cast<int64_t>(wpq) * (RhoOf<kPotts>(pr, alpha, fq_new) -
                                           RhoOf<kPotts>(pr, fp, labels[qz]));
        };
        const Neighbours& e = nb[pz];
        pair(p + 1, e.right);
        pair(p - 1, e.left);
        pair(p + w, e.down);
        pair(p - w, e.up);
      }
      if (delta < 0) {
        ++tick;
        for (int p : changed) {
          const size_t pz = static_cast<size_t>(p);
          labels[pz] = alpha;
          cur[pz] = da[p];
          const Neighbours& e = nb[pz];
          stamp[pz] = tick;
          if (e.right != 0) stamp[pz + 1] = tick;
          if (e.left != 0) stamp[pz - 1] = tick;
          if (e.down != 0) stamp[pz + static_cast<size_t>(w)] = tick;
          if (e.up != 0) stamp[pz - static_cast<size_t>(w)] = tick;
        }
        energy += delta;
        improved = true;
        ++stats.accepted;
      }
      last_run[static_cast<size_t>(alpha)] = tick;
      for (int p : changed) moved[static_cast<size_t>(p)] = 0;
      for (int p : free_px) node[static_cast<size_t>(p)] = -1;
    }
    if (!improved) break;
  }
  stats.energy_after = energy;
  stats.total_seconds = Seconds(t_start, Clock::now());
  return stats;
}

}  // namespace

absl::StatusOr<SolverStats> AlphaExpansion(const MrfProblem& pr,
                                           std::vector<int32_t>* labels_ptr,
                                           int max_cycles,
                                           bool prune_dominated) {
  if (absl::Status s = CheckProblem(pr); !s.ok()) return s;
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
    return pr.potts
               ? Expand<true>(pr, *labels_ptr, max_cycles, prune_dominated)
               : Expand<false>(pr, *labels_ptr, max_cycles, prune_dominated);
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError("fusion: out of memory in max-flow");
  }
}

absl::StatusOr<FusionResult> FuseAlphaExpansion(
    const std::vector<cv::Mat>& candidates, const cv::Mat& guide,
    const FusionParams& params, const std::vector<cv::Mat>& confidences) {
  const Clock::time_point t0 = Clock::now();
  absl::StatusOr<MrfProblem> pr =
      BuildProblem(candidates, guide, params, confidences);
  if (!pr.ok()) return pr.status();
  std::vector<int32_t> labels = WinnerTakesAll(*pr);
  const double setup = Seconds(t0, Clock::now());
  absl::StatusOr<SolverStats> stats =
      AlphaExpansion(*pr, &labels, params.max_cycles, params.prune_dominated);
  if (!stats.ok()) return stats.status();
  FusionResult result;
  result.stats = *stats;
  result.stats.setup_seconds = setup;
  result.disparity.create(pr->height, pr->width, CV_32FC1);
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
  if (absl::Status s = CheckCandidates(candidates, max_disp); !s.ok()) {
    return s;
  }
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
        if (Valid(z, max_disp)) values.push_back(z);
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
