// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/stereo/cost_volume_stereo.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/filters/guided_filter.h"
#include "processing/hdr/merge.h"

namespace hdrstereo::stereo {
namespace {

// Value an out-of-image partner pixel is compared with (Hosni's code).
constexpr float kBorderValue = 3.0f / 255.0f;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

bool IsHdr(CostMode mode) { return mode != CostMode::kLdr; }

absl::Status CheckInput(const cv::Mat& m, const char* what, bool hdr) {
  if (m.empty())
    return absl::InvalidArgumentError(absl::StrCat(what, " is empty"));
  if (m.dims != 2 || m.rows < 2 || m.cols < 2) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " must be a 2-D image of at least 2x2 pixels, got ",
                     m.cols, "x", m.rows));
  }
  if (m.channels() != 1 && m.channels() != 3) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " must have 1 or 3 channels, got ", m.channels()));
  }
  const int depth = m.depth();
  if (hdr && depth != CV_32F) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": HDR matching needs float (CV_32F) radiance"));
  }
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " must be 8-bit, 16-bit or float"));
  }
  if (depth == CV_32F) {
    if (!cv::checkRange(m, /*quiet=*/true)) {
      return absl::InvalidArgumentError(
          absl::StrCat(what, " contains NaN or Inf values"));
    }
    double lo = 0;
    cv::minMaxLoc(m.reshape(1), &lo, nullptr);
    if (hdr && lo < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(what, " has negative radiance (min ", lo, ")"));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckOptions(const StereoOptions& o, int width) {
  if (o.max_disparity <= o.min_disparity) {
    return absl::InvalidArgumentError(absl::StrCat("max disparity (",
                                                   o.max_disparity,
                                                   ") must be greater than min "
                                                   "disparity (",
                                                   o.min_disparity, ")"));
  }
  if (std::max(std::abs(o.min_disparity), std::abs(o.max_disparity)) >= width) {
    return absl::InvalidArgumentError(absl::StrCat(
        "disparity range [", o.min_disparity, ", ", o.max_disparity,
        "] is wider than the image (", width, " pixels)"));
  }
  if (o.radius < 1 || !(o.eps > 0) || !std::isfinite(o.eps)) {
    return absl::InvalidArgumentError(
        "guided filter needs radius >= 1, eps > 0");
  }
  if (!(o.alpha >= 0 && o.alpha <= 1) || !(o.tau_color > 0) ||
      !(o.tau_gradient > 0)) {
    return absl::InvalidArgumentError(
        "cost needs alpha in [0,1] and positive truncations");
  }
  if (o.weighted_median &&
      (o.median_radius < 1 || !(o.sigma_s > 0) || !(o.sigma_c > 0))) {
    return absl::InvalidArgumentError(
        "weighted median needs radius >= 1 and positive sigmas");
  }
  if (o.lr_tolerance < 0 || o.threads < 0) {
    return absl::InvalidArgumentError("lr_tolerance and threads must be >= 0");
  }
  return absl::OkStatus();
}

cv::Mat ToUnitFloat(const cv::Mat& m) {
  cv::Mat out;
  const double scale = m.depth() == CV_8U    ? 1.0 / 255.0
                       : m.depth() == CV_16U ? 1.0 / 65535.0
                                             : 1.0;
  m.convertTo(out, CV_32F, scale);
  return out;
}

// Rec. 601 luma (MATLAB rgb2gray) of a BGR or grey [0,1] image.
cv::Mat Luma601(const cv::Mat& img) {
  if (img.channels() == 1) return img;
  cv::Mat out;
  cv::transform(img, out, cv::Matx13f(0.114f, 0.587f, 0.299f));
  return out;
}

// Central x-difference (x+1 - x-1) / 2, one-sided at the borders (MATLAB
// gradient()).
cv::Mat GradientX(const cv::Mat& g) {
  cv::Mat out(g.size(), CV_32FC1);
  const int w = g.cols;
  for (int y = 0; y < g.rows; ++y) {
    const float* p = g.ptr<float>(y);
    float* o = out.ptr<float>(y);
    o[0] = p[1] - p[0];
    o[w - 1] = p[w - 1] - p[w - 2];
    for (int x = 1; x < w - 1; ++x) o[x] = 0.5f * (p[x + 1] - p[x - 1]);
  }
  return out;
}

// The given percentile of all channel values of both images (100 = max).
double WhitePoint(const cv::Mat& a, const cv::Mat& b, double percentile) {
  double max_a = 0, max_b = 0;
  cv::minMaxLoc(a.reshape(1), nullptr, &max_a);
  cv::minMaxLoc(b.reshape(1), nullptr, &max_b);
  if (percentile >= 100.0) return std::max(max_a, max_b);
  std::vector<float> v;
  v.reserve(a.total() * a.channels() * 2);
  for (const cv::Mat* m : {&a, &b}) {
    cv::Mat c = m->isContinuous() ? *m : m->clone();
    const float* p = c.ptr<float>();
    v.insert(v.end(), p, p + c.total() * c.channels());
  }
  const size_t k = std::min(v.size() - 1,
                            static_cast<size_t>(percentile / 100.0 * v.size()));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k),
                   v.end());
  return v[k];
}

int ThreadCount(const StereoOptions& o) {
  return o.threads > 0 ? o.threads : std::max(1, cv::getNumThreads());
}

absl::Status CheckMatchingImages(const MatchingImages& m,
                                 const StereoOptions& o) {
  if (m.left.empty() || m.left.size() != m.right.size() ||
      m.left.type() != m.right.type() || m.left.depth() != CV_32F ||
      m.left_grad.size() != m.left.size() ||
      m.right_grad.size() != m.left.size() || m.left_grad.type() != CV_32FC1 ||
      m.right_grad.type() != CV_32FC1) {
    return absl::InvalidArgumentError("matching images missing or mismatched");
  }
  return CheckOptions(o, m.left.cols);
}

// ---------------------------------------------------------------------------
// Fused slice kernel.
//
// The image is cut into tiles (strips of rows x ranges of columns, each with
// a halo of 2r); per tile, a block of disparities at a time, rows stream
// through three stages, each row computed once per disparity and kept in a
// ring of 2r + 2 rows:
//   cost row j:    p (Eq. 4.1/4.2) minus a constant centre;
//   stage-1 row i: vertical window sums of p and I_c p (running sums,
//                  recomputed from the ring every kRefreshRows rows so that
//                  float rounding cannot drift), horizontal window sums,
//                  then the guided filter's a = (Sigma + eps)^-1 cov(I, p)
//                  and b;
//   output row y:  the same two box passes over a and b, q = mean(a) I +
//                  mean(b), and the running WTA update.
// Borders are reflected (BORDER_REFLECT, as cv::boxFilter in the guided
// filter). The guide is centred (I - 0.5) and the cost by half its maximum:
// the filter's output shifts by the cost centre only, and the smaller
// magnitudes keep the float sums accurate. Nothing full-size is written per
// slice; a tile's rings stay in L2 and each row of the guide statistics is
// read once per block of disparities.

// Virtual row/column v -> real index, BORDER_REFLECT (tables for the few
// virtual indices the kernel touches; tiny images reflect repeatedly).
class ReflectTable {
 public:
  ReflectTable(int n, int margin) : margin_(margin) {
    table_.resize(static_cast<size_t>(n + 2 * margin));
    for (int v = -margin; v < n + margin; ++v) {
      table_[static_cast<size_t>(v + margin)] =
          cv::borderInterpolate(v, n, cv::BORDER_REFLECT);
    }
  }
  int size() const { return static_cast<int>(table_.size()) - 2 * margin_; }
  int operator()(int v) const {
    return table_[static_cast<size_t>(v + margin_)];
  }

 private:
  int margin_;
  std::vector<int> table_;
};

// One view's inputs as planes (structure of arrays), plus the guide
// statistics that every slice reuses.
struct ViewPlanes {
  int w = 0, h = 0, nc = 0;
  std::vector<cv::Mat> own, other;  // matching images, nc planes each
  cv::Mat own_grad, other_grad;
  std::vector<cv::Mat> guide;  // own - kGuideCentre
  std::vector<cv::Mat> mean;   // box means of the guide planes
  std::vector<cv::Mat>
      inv;              // (Sigma + eps)^-1: 1 plane, or 6 (rr rg rb gg gb bb)
  int shift_sign = -1;  // partner of x is x + shift_sign * d
};

constexpr float kGuideCentre = 0.5f;

cv::Mat BoxMean(const cv::Mat& m, int r) {
  cv::Mat out;
  cv::boxFilter(m, out, CV_32F, cv::Size(2 * r + 1, 2 * r + 1),
                cv::Point(-1, -1), /*normalize=*/true, cv::BORDER_REFLECT);
  return out;
}

ViewPlanes MakeViewPlanes(const MatchingImages& m, const StereoOptions& o,
                          View view) {
  ViewPlanes v;
  const bool left = view == View::kLeft;
  const cv::Mat& own = left ? m.left : m.right;
  v.w = own.cols;
  v.h = own.rows;
  v.nc = own.channels();
  cv::split(own, v.own);
  cv::split(left ? m.right : m.left, v.other);
  v.own_grad = left ? m.left_grad : m.right_grad;
  v.other_grad = left ? m.right_grad : m.left_grad;
  v.shift_sign = left ? -1 : 1;
  for (const cv::Mat& p : v.own) {
    cv::Mat g;
    cv::subtract(p, kGuideCentre, g);
    v.guide.push_back(g);
    v.mean.push_back(BoxMean(g, o.radius));
  }
  const float eps = static_cast<float>(o.eps);
  const cv::Size sz(v.w, v.h);
  if (v.nc == 1) {
    const cv::Mat corr = BoxMean(v.guide[0].mul(v.guide[0]), o.radius);
    v.inv.assign(1, cv::Mat(sz, CV_32FC1));
    for (int y = 0; y < v.h; ++y) {
      const float* mu = v.mean[0].ptr<float>(y);
      const float* c = corr.ptr<float>(y);
      float* out = v.inv[0].ptr<float>(y);
      for (int x = 0; x < v.w; ++x)
        out[x] = 1.0f / (c[x] - mu[x] * mu[x] + eps);
    }
    return v;
  }
  // Colour guide: covariance per pixel, inverted in closed form.
  const int pairs[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
  cv::Mat corr[6];
  for (int k = 0; k < 6; ++k) {
    corr[k] = BoxMean(v.guide[static_cast<size_t>(pairs[k][0])].mul(
                          v.guide[static_cast<size_t>(pairs[k][1])]),
                      o.radius);
  }
  v.inv.resize(6);
  for (cv::Mat& p : v.inv) p.create(sz, CV_32FC1);
  for (int y = 0; y < v.h; ++y) {
    const float* m[3] = {v.mean[0].ptr<float>(y), v.mean[1].ptr<float>(y),
                         v.mean[2].ptr<float>(y)};
    const float* c[6];
    float* out[6];
    for (int k = 0; k < 6; ++k) {
      c[k] = corr[k].ptr<float>(y);
      out[k] = v.inv[static_cast<size_t>(k)].ptr<float>(y);
    }
    filters::InvertGuideCovarianceRow(m, c, eps, v.w, out);
  }
  return v;
}

struct CostParams {
  float alpha, beta, t1, t2, inv_nc;
};

CostParams MakeCostParams(const StereoOptions& o, int nc) {
  const float alpha = static_cast<float>(o.alpha);
  return {alpha, 1.0f - alpha, static_cast<float>(o.tau_color),
          static_cast<float>(o.tau_gradient), 1.0f / static_cast<float>(nc)};
}

// Half the largest cost: subtracted from every cost before filtering.
float CostCentre(const CostParams& cp) {
  return 0.5f * (cp.alpha * cp.t1 + cp.beta * cp.t2);
}

// w costs of one row (step 2): a/ga point into the view's own planes, b/gb
// into the other view's (both at the same column); the partner of x is
// x + shift, inside the image for partner offsets in [lo, hi), else
// compared with kBorderValue.
template <int NC>
inline void CostRowRange(const float* const* a, const float* const* b,
                         const float* ga, const float* gb, int w, int lo,
                         int hi, int shift, const CostParams& cp,
                         float* __restrict out) {
  const int x0 = std::clamp(lo - shift, 0, w);
  const int x1 = std::clamp(hi - shift, x0, w);
  auto border = [&](int x) {
    float cd = 0;
    for (int c = 0; c < NC; ++c) cd += std::abs(a[c][x] - kBorderValue);
    if (NC == 3) cd *= cp.inv_nc;
    const float gd = std::abs(ga[x] - kBorderValue);
    out[x] = cp.alpha * std::min(cd, cp.t1) + cp.beta * std::min(gd, cp.t2);
  };
  for (int x = 0; x < x0; ++x) border(x);
  for (int x = x1; x < w; ++x) border(x);
  const float* __restrict gbs = gb + shift;
  if constexpr (NC == 3) {
    const float* __restrict a0 = a[0];
    const float* __restrict a1 = a[1];
    const float* __restrict a2 = a[2];
    const float* __restrict b0 = b[0] + shift;
    const float* __restrict b1 = b[1] + shift;
    const float* __restrict b2 = b[2] + shift;
#pragma GCC ivdep
    for (int x = x0; x < x1; ++x) {
      const float cd = (std::abs(a0[x] - b0[x]) + std::abs(a1[x] - b1[x]) +
                        std::abs(a2[x] - b2[x])) *
                       cp.inv_nc;
      const float gd = std::abs(ga[x] - gbs[x]);
      out[x] = cp.alpha * std::min(cd, cp.t1) + cp.beta * std::min(gd, cp.t2);
    }
  } else {
    const float* __restrict a0 = a[0];
    const float* __restrict b0 = b[0] + shift;
#pragma GCC ivdep
    for (int x = x0; x < x1; ++x) {
      const float cd = std::abs(a0[x] - b0[x]);
      const float gd = std::abs(ga[x] - gbs[x]);
      out[x] = cp.alpha * std::min(cd, cp.t1) + cp.beta * std::min(gd, cp.t2);
    }
  }
}

// out[x] (+)= sum over j < digit of t[x + j * block], x in [0, w).
inline void AddBlocks(const float* __restrict t, int block, int digit, int w,
                      bool first, float* __restrict out) {
  const float* __restrict t1 = t + block;
  const float* __restrict t2 = t + 2 * block;
  if (first) {
    if (digit == 1) {
      for (int x = 0; x < w; ++x) out[x] = t[x];
    } else if (digit == 2) {
      for (int x = 0; x < w; ++x) out[x] = t[x] + t1[x];
    } else {
      for (int x = 0; x < w; ++x) out[x] = t[x] + t1[x] + t2[x];
    }
  } else {
    if (digit == 1) {
      for (int x = 0; x < w; ++x) out[x] += t[x];
    } else if (digit == 2) {
      for (int x = 0; x < w; ++x) out[x] += t[x] + t1[x];
    } else {
      for (int x = 0; x < w; ++x) out[x] += t[x] + t1[x] + t2[x];
    }
  }
}

// next[i] = sum of 4 consecutive blocks of t, pairwise (the same values as
// two doubling steps).
inline void QuadrupleBlocks(const float* __restrict t, int block, int n,
                            float* __restrict next) {
  const float* __restrict t1 = t + block;
  const float* __restrict t2 = t + 2 * block;
  const float* __restrict t3 = t + 3 * block;
  for (int i = 0; i < n; ++i) next[i] = (t[i] + t1[i]) + (t2[i] + t3[i]);
}

// Horizontal window sums over a column range: out[x] for image columns
// [o0, o1) is the sum of src over columns reflect(o0 + x + k), k in [-r, r],
// where src holds image columns [s0, ...) (all the reflected columns must be
// there). Summed along the base-4 digits of 2r + 1 from sums of 1, 4, 16,
// ... neighbours (19 = 3 x 1 + 1 x 16: 4 passes): vectorisable, no
// running-sum drift, and every column sums in the same order whatever the
// range, so tiles give the same values as a full row. pad, t0, t1: scratch
// of o1 - o0 + 2r floats (pad only used next to the image borders).
inline void HorizontalBox(const float* src, int s0, int o0, int o1, int r,
                          const ReflectTable& cols, float* pad, float* t0,
                          float* t1, float* out) {
  const int w = o1 - o0;
  const int n = w + 2 * r;
  const int v0 = o0 - r;  // image column of element 0
  const float* cur = src + (v0 - s0);
  if (v0 < 0 || v0 + n > cols.size()) {
    const int inner0 = std::clamp(-v0, 0, n);
    const int inner1 = std::clamp(cols.size() - v0, inner0, n);
    for (int i = 0; i < inner0; ++i) pad[i] = src[cols(v0 + i) - s0];
    std::copy(src + (v0 + inner0 - s0), src + (v0 + inner1 - s0), pad + inner0);
    for (int i = inner1; i < n; ++i) pad[i] = src[cols(v0 + i) - s0];
    cur = pad;
  }
  float* bufs[2] = {t0, t1};
  int which = 0;
  int rest = 2 * r + 1;
  int block = 1;
  int offset = 0;
  bool first = true;
  while (true) {
    const int digit = rest % 4;
    if (digit > 0) {
      AddBlocks(cur + offset, block, digit, w, first, out);
      first = false;
      offset += digit * block;
    }
    rest /= 4;
    if (rest == 0) break;
    // Sums of 4 * block neighbours, for the columns still needed.
    const int valid = n - 4 * block + 1;
    QuadrupleBlocks(cur, block, valid, bufs[which]);
    cur = bufs[which];
    which ^= 1;
    block *= 4;
  }
}

// Row updates of the vertical window sums (restrict parameters so that GCC
// vectorises them after inlining).
inline void AddRow(const float* __restrict a, int w, float* __restrict s) {
  for (int x = 0; x < w; ++x) s[x] += a[x];
}
inline void AddProductRow(const float* __restrict g, const float* __restrict p,
                          int w, float* __restrict s) {
  for (int x = 0; x < w; ++x) s[x] += g[x] * p[x];
}
inline void MoveWindow(const float* __restrict add, const float* __restrict sub,
                       int w, float* __restrict s) {
  for (int x = 0; x < w; ++x) s[x] += add[x] - sub[x];
}
inline void MoveProductWindow(const float* __restrict ga,
                              const float* __restrict pa,
                              const float* __restrict gs,
                              const float* __restrict ps, int w,
                              float* __restrict s) {
  for (int x = 0; x < w; ++x) s[x] += ga[x] * pa[x] - gs[x] * ps[x];
}

// Stage 1, colour guide: from the window sums of p and I_c p (sp, s0..s2)
// the coefficients a = (Sigma + eps)^-1 cov(I, p) and b = mean(p) - a.mean(I).
inline void Coefficients3(
    const float* __restrict sp, const float* __restrict s0,
    const float* __restrict s1, const float* __restrict s2,
    const float* __restrict m0, const float* __restrict m1,
    const float* __restrict m2, const float* __restrict rr,
    const float* __restrict rg, const float* __restrict rb,
    const float* __restrict gg, const float* __restrict gb,
    const float* __restrict bb, float k, int w, float* __restrict a0,
    float* __restrict a1, float* __restrict a2, float* __restrict b) {
#pragma GCC ivdep
  for (int x = 0; x < w; ++x) {
    const float mp = sp[x] * k;
    const float c0 = s0[x] * k - m0[x] * mp;
    const float c1 = s1[x] * k - m1[x] * mp;
    const float c2 = s2[x] * k - m2[x] * mp;
    const float e0 = rr[x] * c0 + rg[x] * c1 + rb[x] * c2;
    const float e1 = rg[x] * c0 + gg[x] * c1 + gb[x] * c2;
    const float e2 = rb[x] * c0 + gb[x] * c1 + bb[x] * c2;
    a0[x] = e0;
    a1[x] = e1;
    a2[x] = e2;
    b[x] = mp - e0 * m0[x] - e1 * m1[x] - e2 * m2[x];
  }
}

// Stage 1, grey guide.
inline void Coefficients1(const float* __restrict sp,
                          const float* __restrict s0,
                          const float* __restrict m0,
                          const float* __restrict inv, float k, int w,
                          float* __restrict a0, float* __restrict b) {
#pragma GCC ivdep
  for (int x = 0; x < w; ++x) {
    const float mp = sp[x] * k;
    const float e0 = (s0[x] * k - m0[x] * mp) * inv[x];
    a0[x] = e0;
    b[x] = mp - e0 * m0[x];
  }
}

// Stage 2: q = mean(a) . I + mean(b) from the window sums of a_c and b.
template <int NC>
inline float FilteredCost(const float* __restrict sa0,
                          const float* __restrict sa1,
                          const float* __restrict sa2,
                          const float* __restrict sb,
                          const float* __restrict g0,
                          const float* __restrict g1,
                          const float* __restrict g2, float k, int x) {
  if constexpr (NC == 3) {
    return (sa0[x] * g0[x] + sa1[x] * g1[x] + sa2[x] * g2[x] + sb[x]) * k;
  } else {
    return (sa0[x] * g0[x] + sb[x]) * k;
  }
}

template <int NC>
inline void FilteredRow(const float* __restrict sa0,
                        const float* __restrict sa1,
                        const float* __restrict sa2, const float* __restrict sb,
                        const float* __restrict g0, const float* __restrict g1,
                        const float* __restrict g2, float k, int w,
                        float* __restrict q) {
#pragma GCC ivdep
  for (int x = 0; x < w; ++x) {
    q[x] = FilteredCost<NC>(sa0, sa1, sa2, sb, g0, g1, g2, k, x);
  }
}

// Stage 2 fused with the WTA update (strictly better wins: ties keep the
// smaller disparity).
template <int NC>
inline void FilteredRowWta(
    const float* __restrict sa0, const float* __restrict sa1,
    const float* __restrict sa2, const float* __restrict sb,
    const float* __restrict g0, const float* __restrict g1,
    const float* __restrict g2, float k, float fd, bool first, int w,
    float* __restrict best, float* __restrict label) {
  if (first) {
#pragma GCC ivdep
    for (int x = 0; x < w; ++x) {
      best[x] = FilteredCost<NC>(sa0, sa1, sa2, sb, g0, g1, g2, k, x);
      label[x] = fd;
    }
    return;
  }
// (Written so that GCC 12 if-converts and vectorises it: one select and a
// min; equal costs give the same best either way.)
#pragma GCC ivdep
  for (int x = 0; x < w; ++x) {
    const float q = FilteredCost<NC>(sa0, sa1, sa2, sb, g0, g1, g2, k, x);
    const float b = best[x];
    label[x] = q < b ? fd : label[x];
    best[x] = std::min(q, b);
  }
}

// WTA update that also tracks the costs at label - 1 (before) and label + 1
// (after); prev holds the costs at fd - 1.
inline void SubpixelWta(const float* __restrict q, const float* __restrict prev,
                        float fd, int w, float* __restrict best,
                        float* __restrict label, float* __restrict before,
                        float* __restrict after) {
  const float fprev = fd - 1.0f;
#pragma GCC ivdep
  for (int x = 0; x < w; ++x) {
    const float v = q[x];
    const float b = best[x];
    const float l = label[x];
    const bool better = v < b;
    const float af = l == fprev ? v : after[x];
    best[x] = better ? v : b;
    label[x] = better ? fd : l;
    before[x] = better ? prev[x] : before[x];
    after[x] = better ? kNaN : af;
  }
}

// Where the WTA of one strip goes (rows of the full-size result).
struct WtaTarget {
  cv::Mat* best;    // CV_32FC1, centred filtered cost of the winner
  cv::Mat* label;   // CV_32FC1
  cv::Mat* before;  // CV_32FC1, cost at label - 1 (sub-pixel only)
  cv::Mat* after;   // CV_32FC1, cost at label + 1 (sub-pixel only)
};

template <int NC>
class SliceKernel {
 public:
  static constexpr int kQ = NC + 1;  // quantities per stage: p, I_c p / a_c, b
  // Disparities processed together, row by row: each row of the guide
  // statistics is read once per block instead of once per disparity.
  static constexpr int kBlock = 4;
  // The vertical running sums are recomputed from the ring every so many
  // rows, which bounds their float drift (and the first row of a strip).
  static constexpr int kRefreshRows = 64;

  // Tiles of at most max_cols output columns.
  SliceKernel(const ViewPlanes& v, const StereoOptions& o, int max_cols)
      : v_(v),
        r_(o.radius),
        ring_(2 * o.radius + 2),
        rows_(v.h, 2 * o.radius + 2),
        cols_(v.w, o.radius),
        cp_(MakeCostParams(o, NC)),
        cost_centre_(CostCentre(cp_)),
        inv_area_(1.0f /
                  static_cast<float>((2 * o.radius + 1) * (2 * o.radius + 1))) {
    const size_t w0 = static_cast<size_t>(std::min(v.w, max_cols + 4 * r_));
    const size_t w1 = static_cast<size_t>(std::min(v.w, max_cols + 2 * r_));
    const size_t padded = static_cast<size_t>(max_cols + 4 * r_);
    const size_t slots = kBlock;
    stride0_ = w0;
    stride1_ = w1;
    ring1_.assign(slots * static_cast<size_t>(ring_) * w0, 0.0f);
    ring2_.assign(slots * static_cast<size_t>(ring_ * kQ) * w1, 0.0f);
    sum1_.assign(slots * kQ * w0, 0.0f);
    sum2_.assign(slots * kQ * w1, 0.0f);
    box_.assign(kQ * w1, 0.0f);
    q_row_.assign(w1, 0.0f);
    pad_.assign(3 * padded, 0.0f);
  }

  // Disparities [d0, d1] in order for output rows [y0, y1), columns
  // [x0, x1).
  void Run(int y0, int y1, int x0, int x1, int d0, int d1, bool subpixel,
           const WtaTarget& t) {
    ox0_ = x0;
    ox1_ = x1;
    sx0_ = std::max(0, x0 - r_);
    sx1_ = std::min(v_.w, x1 + r_);
    cx0_ = std::max(0, sx0_ - r_);
    cx1_ = std::min(v_.w, sx1_ + r_);
    if (subpixel) {
      prev_rows_.assign(static_cast<size_t>((y1 - y0) * (x1 - x0)), 0);
    }
    const int s0 = std::max(0, y0 - r_);
    const int s1 = std::min(v_.h, y1 + r_);
    for (int db = d0; db <= d1; db += kBlock) {
      const int slots = std::min(kBlock, d1 - db + 1);
      int next_cost = std::max(0, s0 - r_);
      int next_out = y0;
      for (int i = s0; i < s1; ++i) {
        const int need = std::min(v_.h - 1, i + r_);
        for (; next_cost <= need; ++next_cost) {
          for (int k = 0; k < slots; ++k) ProduceCostRow(k, db + k, next_cost);
        }
        const bool refresh1 = (i - s0) % kRefreshRows == 0;
        for (int k = 0; k < slots; ++k) Stage1Row(k, i, refresh1);
        for (; next_out < y1 && std::min(v_.h - 1, next_out + r_) <= i;
             ++next_out) {
          const bool refresh2 = (next_out - y0) % kRefreshRows == 0;
          for (int k = 0; k < slots; ++k) {
            OutputRow(k, next_out, db + k, d0, subpixel, refresh2, t, y0);
          }
        }
      }
    }
  }

 private:
  // Cost row j of slot k (row j % ring of its ring, columns from cx0_).
  float* Ring1(int k, int j) {
    return ring1_.data() +
           static_cast<size_t>(k * ring_ + j % ring_) * stride0_;
  }
  // Quantity q of stage-1 row i of slot k (columns from sx0_).
  float* Ring2(int k, int i, int q) {
    return ring2_.data() +
           static_cast<size_t>((k * ring_ + i % ring_) * kQ + q) * stride1_;
  }
  float* Sum1(int k, int q) {
    return sum1_.data() + static_cast<size_t>(k * kQ + q) * stride0_;
  }
  float* Sum2(int k, int q) {
    return sum2_.data() + static_cast<size_t>(k * kQ + q) * stride1_;
  }
  const float* Guide(int c, int row, int col) const {
    return v_.guide[static_cast<size_t>(c)].ptr<float>(row) + col;
  }

  // Cost minus the centre, real row j, disparity d, columns [cx0_, cx1_).
  void ProduceCostRow(int k, int d, int j) {
    const float* a[NC];
    const float* b[NC];
    for (int c = 0; c < NC; ++c) {
      a[c] = v_.own[static_cast<size_t>(c)].ptr<float>(j) + cx0_;
      b[c] = v_.other[static_cast<size_t>(c)].ptr<float>(j) + cx0_;
    }
    // Partner columns, relative to cx0_: [-cx0_, w - cx0_).
    float* __restrict p = Ring1(k, j);
    CostRowRange<NC>(a, b, v_.own_grad.ptr<float>(j) + cx0_,
                     v_.other_grad.ptr<float>(j) + cx0_, cx1_ - cx0_, -cx0_,
                     v_.w - cx0_, v_.shift_sign * d, cp_, p);
    const float centre = cost_centre_;
    const int w = cx1_ - cx0_;
#pragma GCC ivdep
    for (int x = 0; x < w; ++x) p[x] -= centre;
  }

  // Vertical window sums of p and I_c p over virtual rows [i - r, i + r]:
  // from scratch if `refresh`, else by moving the window of row i - 1. The
  // products are formed on the fly (the same rounding as stored ones).
  void Stage1Sums(int k, int i, bool refresh) {
    const int w = cx1_ - cx0_;
    for (int q = 0; q < kQ; ++q) {
      float* __restrict s = Sum1(k, q);
      if (refresh) {
        std::fill(s, s + w, 0.0f);
        for (int t = -r_; t <= r_; ++t) {
          const int row = rows_(i + t);
          const float* __restrict p = Ring1(k, row);
          if (q == 0) {
            AddRow(p, w, s);
          } else {
            AddProductRow(Guide(q - 1, row, cx0_), p, w, s);
          }
        }
      } else {
        const int add_row = rows_(i + r_);
        const int sub_row = rows_(i - r_ - 1);
        const float* __restrict pa = Ring1(k, add_row);
        const float* __restrict ps = Ring1(k, sub_row);
        if (q == 0) {
          MoveWindow(pa, ps, w, s);
        } else {
          MoveProductWindow(Guide(q - 1, add_row, cx0_), pa,
                            Guide(q - 1, sub_row, cx0_), ps, w, s);
        }
      }
    }
  }

  // Guided-filter coefficients a_c, b of real row i, columns [sx0_, sx1_).
  void Stage1Row(int k, int i, bool refresh) {
    Stage1Sums(k, i, refresh);
    const int w = sx1_ - sx0_;
    for (int q = 0; q < kQ; ++q) HBox(Sum1(k, q), cx0_, sx0_, sx1_, q);
    const float* s = box_.data();
    float* out[kQ];
    for (int q = 0; q < kQ; ++q) out[q] = Ring2(k, i, q);
    const size_t st = stride1_;
    const int c = sx0_;
    if constexpr (NC == 3) {
      const std::vector<cv::Mat>& inv = v_.inv;
      const std::vector<cv::Mat>& mean = v_.mean;
      Coefficients3(s, s + st, s + 2 * st, s + 3 * st,
                    mean[0].ptr<float>(i) + c, mean[1].ptr<float>(i) + c,
                    mean[2].ptr<float>(i) + c, inv[0].ptr<float>(i) + c,
                    inv[1].ptr<float>(i) + c, inv[2].ptr<float>(i) + c,
                    inv[3].ptr<float>(i) + c, inv[4].ptr<float>(i) + c,
                    inv[5].ptr<float>(i) + c, inv_area_, w, out[0], out[1],
                    out[2], out[3]);
    } else {
      Coefficients1(s, s + st, v_.mean[0].ptr<float>(i) + c,
                    v_.inv[0].ptr<float>(i) + c, inv_area_, w, out[0], out[1]);
    }
  }

  // Horizontal window sums of quantity q (src from column s0) into box_.
  void HBox(const float* src, int s0, int o0, int o1, int q) {
    const size_t padded = static_cast<size_t>(o1 - o0 + 2 * r_);
    HorizontalBox(src, s0, o0, o1, r_, cols_, pad_.data(), pad_.data() + padded,
                  pad_.data() + 2 * padded,
                  box_.data() + static_cast<size_t>(q) * stride1_);
  }

  // Filtered cost of output row y, disparity d, and the WTA update.
  void OutputRow(int k, int y, int d, int d0, bool subpixel, bool refresh,
                 const WtaTarget& t, int y0) {
    const int ws = sx1_ - sx0_;
    for (int q = 0; q < kQ; ++q) {
      float* __restrict s = Sum2(k, q);
      if (refresh) {
        std::fill(s, s + ws, 0.0f);
        for (int tt = -r_; tt <= r_; ++tt) {
          AddRow(Ring2(k, rows_(y + tt), q), ws, s);
        }
      } else {
        MoveWindow(Ring2(k, rows_(y + r_), q), Ring2(k, rows_(y - r_ - 1), q),
                   ws, s);
      }
      HBox(s, sx0_, ox0_, ox1_, q);
    }
    const int w = ox1_ - ox0_;
    const size_t st = stride1_;
    const float* s = box_.data();
    const float* g0 = Guide(0, y, ox0_);
    const float* g1 = NC == 3 ? Guide(NC - 2, y, ox0_) : nullptr;
    const float* g2 = NC == 3 ? Guide(NC - 1, y, ox0_) : nullptr;
    float* best = t.best->ptr<float>(y) + ox0_;
    float* label = t.label->ptr<float>(y) + ox0_;
    const float fd = static_cast<float>(d);
    if (!subpixel) {
      FilteredRowWta<NC>(s, s + st, s + 2 * st, s + NC * st, g0, g1, g2,
                         inv_area_, fd, d == d0, w, best, label);
      return;
    }
    float* q = q_row_.data();
    FilteredRow<NC>(s, s + st, s + 2 * st, s + NC * st, g0, g1, g2, inv_area_,
                    w, q);
    float* prev = prev_rows_.data() + static_cast<size_t>((y - y0) * w);
    float* before = t.before->ptr<float>(y) + ox0_;
    float* after = t.after->ptr<float>(y) + ox0_;
    if (d == d0) {
      std::copy(q, q + w, best);
      std::fill(label, label + w, fd);
      std::fill(before, before + w, kNaN);
      std::fill(after, after + w, kNaN);
    } else {
      SubpixelWta(q, prev, fd, w, best, label, before, after);
    }
    std::copy(q, q + w, prev);
  }

  const ViewPlanes& v_;
  const int r_;
  const int ring_;     // rows per ring: the window plus the row leaving it
  ReflectTable rows_;  // virtual row -> real row
  ReflectTable cols_;  // virtual column -> real column
  const CostParams cp_;
  const float cost_centre_;
  const float inv_area_;
  // Column ranges of the current tile: output, stage 1, cost.
  int ox0_ = 0, ox1_ = 0, sx0_ = 0, sx1_ = 0, cx0_ = 0, cx1_ = 0;
  size_t stride0_ = 0, stride1_ = 0;  // row lengths of cost / stage-1 data
  std::vector<float> ring1_;          // [slot][row % ring][x]: p - centre
  std::vector<float> ring2_;          // [slot][row % ring][quantity][x]
  std::vector<float> sum1_, sum2_;    // vertical sums [slot][quantity][x]
  std::vector<float> box_;            // window sums [quantity][x]
  std::vector<float> q_row_;          // filtered cost of the current row
  std::vector<float> prev_rows_;      // filtered cost at d - 1 (sub-pixel)
  std::vector<float> pad_;
};

// A thread's share of RunKernel: tiles range.start .. range.end - 1.
struct TileJob {
  const ViewPlanes* v;
  const StereoOptions* o;
  int strip_rows, tile_cols, tiles_per_row;
  cv::Range range;
  int d0, d1;
  bool subpixel;
  const WtaTarget* target;
};

template <int NC>
inline void RunTiles(const TileJob& job) {
  SliceKernel<NC> kernel(*job.v, *job.o, job.tile_cols);
  for (int t = job.range.start; t < job.range.end; ++t) {
    const int ty = t / job.tiles_per_row;
    const int tx = t % job.tiles_per_row;
    kernel.Run(ty * job.strip_rows,
               std::min(job.v->h, (ty + 1) * job.strip_rows),
               tx * job.tile_cols, std::min(job.v->w, (tx + 1) * job.tile_cols),
               job.d0, job.d1, job.subpixel, *job.target);
  }
}

// The kernel with everything inlined, built for AVX2 and for the baseline
// ISA (picked at load time). No FMA: both versions round identically.
__attribute__((flatten, target_clones("avx2", "default"))) void RunTiles3(
    const TileJob& job) {
  RunTiles<3>(job);
}
__attribute__((flatten, target_clones("avx2", "default"))) void RunTiles1(
    const TileJob& job) {
  RunTiles<1>(job);
}

struct KernelOutput {
  cv::Mat best, label, before, after;  // CV_32FC1, full size
  float cost_centre = 0;
};

// Steps 2-4 for disparities [d0, d1] of one view, the image split into
// tiles (row strips x column ranges) shared out over threads; every pixel
// sees the disparities in order, so ties go to the smaller one, and the
// tiling does not depend on the thread count, so neither does the rounding.
template <int NC>
void RunKernel(const ViewPlanes& v, const StereoOptions& o, int d0, int d1,
               bool subpixel, KernelOutput& out) {
  const cv::Size size(v.w, v.h);
  out.best.create(size, CV_32FC1);
  out.label.create(size, CV_32FC1);
  if (subpixel) {
    out.before.create(size, CV_32FC1);
    out.after.create(size, CV_32FC1);
  }
  const WtaTarget target{&out.best, &out.label, &out.before, &out.after};
  // Tiles small enough that the rings of a block of disparities stay in L2;
  // each tile recomputes a halo of 2r rows and columns per side.
  constexpr int kStripRows = 96;
  constexpr int kTileCols = 256;
  const int strip = std::min(kStripRows, v.h);
  const int tile = std::min(kTileCols, v.w);
  const int per_row = (v.w + tile - 1) / tile;
  const int tiles = per_row * ((v.h + strip - 1) / strip);
  const int threads = std::min(ThreadCount(o), tiles);
  auto run = [&](const cv::Range& range) {
    const TileJob job{&v,    &o, strip, tile,     per_row,
                      range, d0, d1,    subpixel, &target};
    if constexpr (NC == 3) {
      RunTiles3(job);
    } else {
      RunTiles1(job);
    }
  };
  out.cost_centre = CostCentre(MakeCostParams(o, NC));
  if (threads == 1) {
    run(cv::Range(0, tiles));
  } else {
    cv::parallel_for_(cv::Range(0, tiles), run, threads);
  }
}

KernelOutput FilteredWta(const MatchingImages& images,
                         const StereoOptions& options, View view, int d0,
                         int d1, bool subpixel) {
  const ViewPlanes v = MakeViewPlanes(images, options, view);
  KernelOutput out;
  if (v.nc == 3) {
    RunKernel<3>(v, options, d0, d1, subpixel, out);
  } else {
    RunKernel<1>(v, options, d0, d1, subpixel, out);
  }
  return out;
}

}  // namespace

absl::StatusOr<MatchingImages> PrepareMatchingImages(
    const cv::Mat& left, const cv::Mat& right, const StereoOptions& options) {
  const bool hdr = IsHdr(options.mode);
  if (absl::Status s = CheckInput(left, "left image", hdr); !s.ok()) return s;
  if (absl::Status s = CheckInput(right, "right image", hdr); !s.ok()) {
    return s;
  }
  if (left.size() != right.size() || left.type() != right.type()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "left and right images differ in size or type (", left.cols, "x",
        left.rows, " vs ", right.cols, "x", right.rows, ")"));
  }
  if (absl::Status s = CheckOptions(options, left.cols); !s.ok()) return s;
  try {
    MatchingImages m;
    if (!hdr) {
      m.left = ToUnitFloat(left);
      m.right = ToUnitFloat(right);
      m.left_grad = GradientX(Luma601(m.left));
      m.right_grad = GradientX(Luma601(m.right));
      return m;
    }
    const double scale = WhitePoint(left, right, options.hdr_white_percentile);
    if (!(scale > 0)) {
      return absl::InvalidArgumentError("HDR pair is black (zero radiance)");
    }
    left.convertTo(m.left, CV_32F, 1.0 / scale);
    right.convertTo(m.right, CV_32F, 1.0 / scale);
    cv::min(m.left, 1.0, m.left);
    cv::min(m.right, 1.0, m.right);
    if (options.mode == CostMode::kHdrRadianceGradient) {
      m.left_grad = GradientX(hdr::Luminance(m.left));
      m.right_grad = GradientX(hdr::Luminance(m.right));
      return m;
    }
    // Eq. 4.2: log10 luminance, rescaled to [0,1] over the pair.
    cv::Mat ll = hdr::LogLuminance(m.left);
    cv::Mat lr = hdr::LogLuminance(m.right);
    double lo_l, hi_l, lo_r, hi_r;
    cv::minMaxLoc(ll, &lo_l, &hi_l);
    cv::minMaxLoc(lr, &lo_r, &hi_r);
    const double lo = std::min(lo_l, lo_r);
    const double span = std::max(hi_l, hi_r) - lo;
    const double k = span > 0 ? 1.0 / span : 0.0;
    ll.convertTo(ll, CV_32F, k, -lo * k);
    lr.convertTo(lr, CV_32F, k, -lo * k);
    m.left_grad = GradientX(ll);
    m.right_grad = GradientX(lr);
    return m;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("stereo: ", e.what()));
  }
}

void ComputeCostSlice(const MatchingImages& images,
                      const StereoOptions& options, View view, int d,
                      cv::Mat& cost) {
  const bool left = view == View::kLeft;
  std::vector<cv::Mat> a, b;
  cv::split(left ? images.left : images.right, a);
  cv::split(left ? images.right : images.left, b);
  const cv::Mat& ga = left ? images.left_grad : images.right_grad;
  const cv::Mat& gb = left ? images.right_grad : images.left_grad;
  const int nc = static_cast<int>(a.size());
  const CostParams cp = MakeCostParams(options, nc);
  const int shift = left ? -d : d;
  cost.create(ga.size(), CV_32FC1);
  for (int y = 0; y < cost.rows; ++y) {
    const float* pa[3];
    const float* pb[3];
    for (int c = 0; c < nc; ++c) {
      pa[c] = a[static_cast<size_t>(c)].ptr<float>(y);
      pb[c] = b[static_cast<size_t>(c)].ptr<float>(y);
    }
    if (nc == 3) {
      CostRowRange<3>(pa, pb, ga.ptr<float>(y), gb.ptr<float>(y), cost.cols, 0,
                      cost.cols, shift, cp, cost.ptr<float>(y));
    } else {
      CostRowRange<1>(pa, pb, ga.ptr<float>(y), gb.ptr<float>(y), cost.cols, 0,
                      cost.cols, shift, cp, cost.ptr<float>(y));
    }
  }
}

absl::StatusOr<cv::Mat> ComputeFilteredCostSlice(const MatchingImages& images,
                                                 const StereoOptions& options,
                                                 View view, int d) {
  if (absl::Status s = CheckMatchingImages(images, options); !s.ok()) return s;
  try {
    KernelOutput k = FilteredWta(images, options, view, d, d, false);
    cv::Mat out;
    cv::add(k.best, k.cost_centre, out);
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("stereo: ", e.what()));
  }
}

absl::StatusOr<WtaResult> ComputeWta(const MatchingImages& images,
                                     const StereoOptions& options, View view) {
  if (absl::Status s = CheckMatchingImages(images, options); !s.ok()) return s;
  try {
    const bool sub = options.subpixel;
    KernelOutput k = FilteredWta(images, options, view, options.min_disparity,
                                 options.max_disparity, sub);
    WtaResult out;
    out.labels = k.label;
    cv::add(k.best, k.cost_centre, out.cost);
    if (!sub) {
      out.disparity = out.labels;
      return out;
    }
    // Parabola through the centred costs (the centre cancels).
    out.disparity = out.labels.clone();
    const int n = static_cast<int>(out.disparity.total());
    float* disp = out.disparity.ptr<float>();
    const float* c0 = k.best.ptr<float>();
    const float* cm = k.before.ptr<float>();
    const float* cp = k.after.ptr<float>();
    for (int i = 0; i < n; ++i) {
      if (std::isnan(cm[i]) || std::isnan(cp[i])) continue;
      const float denom = cm[i] - 2.0f * c0[i] + cp[i];
      if (!(denom > 0)) continue;
      const float offset =
          std::clamp(0.5f * (cm[i] - cp[i]) / denom, -0.5f, 0.5f);
      disp[i] += offset;
    }
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("stereo: ", e.what()));
  }
}

cv::Mat LeftRightCheck(const cv::Mat& disp_left, const cv::Mat& disp_right,
                       float tolerance) {
  cv::Mat valid(disp_left.size(), CV_8UC1, cv::Scalar(0));
  const int w = disp_left.cols;
  for (int y = 0; y < disp_left.rows; ++y) {
    const float* dl = disp_left.ptr<float>(y);
    const float* dr = disp_right.ptr<float>(y);
    uint8_t* v = valid.ptr<uint8_t>(y);
    for (int x = 0; x < w; ++x) {
      if (!std::isfinite(dl[x])) continue;
      const int xr = x - static_cast<int>(std::lround(dl[x]));
      if (xr < 0 || xr >= w || !std::isfinite(dr[xr])) continue;
      if (std::abs(dl[x] - dr[xr]) <= tolerance) v[x] = 255;
    }
  }
  return valid;
}

void FillScanlines(cv::Mat& disparity, const cv::Mat& valid, float fallback) {
  const int w = disparity.cols;
  std::vector<float> left_val(static_cast<size_t>(w));
  for (int y = 0; y < disparity.rows; ++y) {
    float* d = disparity.ptr<float>(y);
    const uint8_t* v = valid.ptr<uint8_t>(y);
    float last = kNaN;
    for (int x = 0; x < w; ++x) {
      if (v[x]) last = d[x];
      left_val[static_cast<size_t>(x)] = last;
    }
    float next = kNaN;
    for (int x = w - 1; x >= 0; --x) {
      if (v[x]) {
        next = d[x];
        continue;
      }
      const float l = left_val[static_cast<size_t>(x)];
      if (std::isnan(l) && std::isnan(next)) {
        d[x] = fallback;
      } else if (std::isnan(l)) {
        d[x] = next;
      } else if (std::isnan(next)) {
        d[x] = l;
      } else {
        d[x] = std::min(l, next);
      }
    }
  }
}

cv::Mat WeightedMedian(const cv::Mat& disparity, const cv::Mat& valid,
                       const cv::Mat& guide, int dmin, int dmax, int radius,
                       double sigma_s, double sigma_c) {
  cv::Mat out = disparity.clone();
  const int labels = dmax - dmin + 1;
  const int side = 2 * radius + 1;
  std::vector<float> spatial(static_cast<size_t>(side * side));
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      spatial[static_cast<size_t>((dy + radius) * side + dx + radius)] =
          static_cast<float>(
              std::exp(-(dx * dx + dy * dy) / (sigma_s * sigma_s)));
    }
  }
  // exp(-dist2 / sigma_c^2) tabulated up to dist2 = 20 sigma_c^2 (weight
  // e^-20 beyond, taken as 0).
  constexpr int kLut = 4096;
  const double max_dist2 = 20.0 * sigma_c * sigma_c;
  const float lut_scale = static_cast<float>(kLut / max_dist2);
  std::vector<float> colour(kLut + 1);
  for (int i = 0; i <= kLut; ++i) {
    colour[static_cast<size_t>(i)] =
        i == kLut ? 0.0f
                  : static_cast<float>(
                        std::exp(-(i + 0.5) / lut_scale / (sigma_c * sigma_c)));
  }
  const int nc = guide.channels();
  const int w = disparity.cols;
  const int h = disparity.rows;
  // Labels 0..labels-1 once, not per neighbour.
  cv::Mat label_img(disparity.size(), CV_32SC1);
  for (int y = 0; y < h; ++y) {
    const float* d = disparity.ptr<float>(y);
    int* l = label_img.ptr<int>(y);
    for (int x = 0; x < w; ++x) {
      const float v = std::isfinite(d[x]) ? d[x] : static_cast<float>(dmin);
      l[x] = std::clamp(static_cast<int>(std::lround(v)) - dmin, 0, labels - 1);
    }
  }
  // Four interleaved histograms (neighbour x mod 4): consecutive neighbours
  // mostly share a label, and one histogram would chain every addition
  // through the same memory location.
  constexpr int kCopies = 4;
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    std::vector<float> hists(static_cast<size_t>(kCopies * labels));
    std::vector<float> hist(static_cast<size_t>(labels));
    for (int y = rows.start; y < rows.end; ++y) {
      const uint8_t* v = valid.ptr<uint8_t>(y);
      const float* gi = guide.ptr<float>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < w; ++x) {
        if (v[x]) continue;
        std::fill(hists.begin(), hists.end(), 0.0f);
        const float* ci = gi + x * nc;
        for (int yy = std::max(0, y - radius);
             yy <= std::min(h - 1, y + radius); ++yy) {
          const float* gj = guide.ptr<float>(yy);
          const int* lj = label_img.ptr<int>(yy);
          const float* sw =
              spatial.data() +
              static_cast<size_t>((yy - y + radius) * side + radius);
          for (int xx = std::max(0, x - radius);
               xx <= std::min(w - 1, x + radius); ++xx) {
            const float* cj = gj + xx * nc;
            float dist2 = 0;
            for (int c = 0; c < nc; ++c) {
              const float t = ci[c] - cj[c];
              dist2 += t * t;
            }
            const int bin = std::min(kLut, static_cast<int>(dist2 * lut_scale));
            const float wgt = sw[xx - x] * colour[static_cast<size_t>(bin)];
            hists[static_cast<size_t>((xx % kCopies) * labels + lj[xx])] += wgt;
          }
        }
        float total = 0;
        for (int l = 0; l < labels; ++l) {
          float sum = 0;
          for (int k = 0; k < kCopies; ++k) {
            sum += hists[static_cast<size_t>(k * labels + l)];
          }
          hist[static_cast<size_t>(l)] = sum;
          total += sum;
        }
        if (!(total > 0)) continue;
        float acc = 0;
        const float half = 0.5f * total;
        for (int l = 0; l < labels; ++l) {
          acc += hist[static_cast<size_t>(l)];
          if (acc >= half) {
            o[x] = static_cast<float>(l + dmin);
            break;
          }
        }
      }
    }
  });
  return out;
}

absl::StatusOr<StereoResult> ComputeDisparity(const cv::Mat& left,
                                              const cv::Mat& right,
                                              const StereoOptions& options) {
  absl::StatusOr<MatchingImages> images =
      PrepareMatchingImages(left, right, options);
  if (!images.ok()) return images.status();
  try {
    // The right view's WTA is only needed for the check; sub-pixel refinement
    // only for the left view.
    absl::StatusOr<WtaResult> wl = ComputeWta(*images, options, View::kLeft);
    if (!wl.ok()) return wl.status();
    StereoResult result;
    result.raw_left = wl->labels;
    if (!options.left_right_check) {
      result.consistent = cv::Mat(left.size(), CV_8UC1, cv::Scalar(255));
      result.disparity = wl->disparity.clone();
      return result;
    }
    StereoOptions right_options = options;
    right_options.subpixel = false;
    absl::StatusOr<WtaResult> wr =
        ComputeWta(*images, right_options, View::kRight);
    if (!wr.ok()) return wr.status();
    result.raw_right = wr->labels;
    result.consistent = LeftRightCheck(
        wl->labels, wr->labels, static_cast<float>(options.lr_tolerance));
    cv::Mat disp = wl->labels.clone();
    if (options.fill) {
      FillScanlines(disp, result.consistent,
                    static_cast<float>(options.min_disparity));
      if (options.weighted_median) {
        disp = WeightedMedian(disp, result.consistent, images->left,
                              options.min_disparity, options.max_disparity,
                              options.median_radius, options.sigma_s,
                              options.sigma_c);
      }
    }
    if (options.subpixel) wl->disparity.copyTo(disp, result.consistent);
    result.disparity = disp;
    return result;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("stereo: ", e.what()));
  }
}

}  // namespace hdrstereo::stereo
