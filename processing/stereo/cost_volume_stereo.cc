// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/stereo/cost_volume_stereo.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
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
  RETURN_IF_ERROR(o.Validate());
  if (std::max(std::abs(o.min_disparity), std::abs(o.max_disparity)) >= width) {
    return absl::InvalidArgumentError(absl::StrCat(
        "disparity range [", o.min_disparity, ", ", o.max_disparity,
        "] is wider than the image (", width, " pixels)"));
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

// The gradient planes of m.left and m.right (step 2's G).
void ComputeGradients(CostMode mode, MatchingImages& m) {
  switch (mode) {
    case CostMode::kLdr:
      m.left_grad = GradientX(Luma601(m.left));
      m.right_grad = GradientX(Luma601(m.right));
      return;
    case CostMode::kHdrRadianceGradient:
      m.left_grad = GradientX(hdr::Luminance(m.left));
      m.right_grad = GradientX(hdr::Luminance(m.right));
      return;
    case CostMode::kHdrLogLuminance: {
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
      return;
    }
  }
}

// Step 5a: per channel, the median of left / right over the consistent
// matches (left labels) where both views are textured (|gradient| >=
// min_grad: a wrong match in a flat region would "explain" the gain by a
// shift and bias the ratio to 1) and lie in [kGainLow, kGainHigh] (not
// dark, not clipped); 1 for a channel with fewer than kGainMinSamples.
constexpr float kGainLow = 16.0f / 255.0f;
constexpr float kGainHigh = 240.0f / 255.0f;
constexpr size_t kGainMinSamples = 1000;
// Gains closer to 1 than this leave the first pass as it is: 0.5 % is less
// than one 8-bit level at mid-grey.
constexpr double kGainTolerance = 0.005;

cv::Scalar EstimateRightGain(const MatchingImages& m, const cv::Mat& labels,
                             const cv::Mat& consistent, float min_grad) {
  const int nc = m.left.channels();
  const int w = m.left.cols;
  std::vector<std::vector<float>> ratios(static_cast<size_t>(nc));
  for (int y = 0; y < m.left.rows; ++y) {
    const float* l = m.left.ptr<float>(y);
    const float* r = m.right.ptr<float>(y);
    const float* d = labels.ptr<float>(y);
    const uint8_t* ok = consistent.ptr<uint8_t>(y);
    const float* gl = m.left_grad.ptr<float>(y);
    const float* gr = m.right_grad.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      if (!ok[x]) continue;
      const int xr = x - static_cast<int>(std::lround(d[x]));
      if (xr < 0 || xr >= w) continue;
      if (std::abs(gl[x]) < min_grad || std::abs(gr[xr]) < min_grad) continue;
      for (int c = 0; c < nc; ++c) {
        const float a = l[x * nc + c];
        const float b = r[xr * nc + c];
        if (a < kGainLow || a > kGainHigh || b < kGainLow || b > kGainHigh) {
          continue;
        }
        ratios[static_cast<size_t>(c)].push_back(a / b);
      }
    }
  }
  cv::Scalar gain = cv::Scalar::all(1);
  for (int c = 0; c < nc; ++c) {
    std::vector<float>& v = ratios[static_cast<size_t>(c)];
    if (v.size() < kGainMinSamples) continue;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    gain[c] = *mid;
  }
  return gain;
}

// ---------------------------------------------------------------------------
// Fused block kernel.
//
// Disparities are processed eight at a time, one per SIMD lane: every
// quantity of the filter is a vector of eight disparities at one pixel, the
// guide's values are broadcast to it, and every step, the horizontal window
// sums included, is lane-wise arithmetic (only the WTA compares lanes). The
// image is cut into tiles (strips of rows x ranges of columns, each with a halo
// of 2r); per tile and block of disparities, rows stream through three stages,
// each kept in a ring of 2r + 2 rows:
//   cost row j:    p (Eq. 4.1/4.2) minus a constant centre;
//   stage-1 row i: vertical window sums of p and I_c p (running sums,
//                  recomputed from the ring every kRefreshRows rows so that
//                  float rounding cannot drift), horizontal running sums
//                  (recomputed every kRefreshCols columns), then the guided
//                  filter's a = (Sigma + eps)^-1 cov(I, p) and b;
//   output row y:  the same two box passes over a and b, q = mean(a) I +
//                  mean(b), and the WTA update.
// Borders are reflected (BORDER_REFLECT, as cv::boxFilter in the guided
// filter). The guide is centred (I - 0.5) and the cost by half its maximum:
// the filter's output shifts by the cost centre only, and the smaller
// magnitudes keep the float sums accurate. The other view is stored padded
// with the border value (and mirrored for the left view), so that the eight
// partners of a pixel are one contiguous load. Nothing full-size is written
// per disparity.

// Eight floats, one per disparity of a block (GCC vector extension: AVX2 in
// the avx2 clone, two SSE registers in the baseline one).
typedef float V8 __attribute__((vector_size(32)));
typedef int32_t I8 __attribute__((vector_size(32)));
constexpr int kLanes = 8;

// Zeroed storage for V8 values, 32-byte aligned: the file is compiled
// without AVX, so GCC gives V8 only 16-byte alignment (and std::vector
// allocates accordingly), but the AVX2 clone's aligned moves need 32.
class V8Buffer {
 public:
  void Reset(size_t n) {
    const size_t bytes = std::max<size_t>(n, 1) * sizeof(V8);
    data_.reset(static_cast<V8*>(std::aligned_alloc(32, bytes)));
    if (data_ == nullptr) throw std::bad_alloc();
    std::memset(static_cast<void*>(data_.get()), 0, bytes);
  }
  V8* data() const { return data_.get(); }

 private:
  struct Free {
    void operator()(V8* p) const { std::free(p); }
  };
  std::unique_ptr<V8, Free> data_;
};

inline V8 Splat(float s) { return V8{} + s; }
inline V8 Load(const float* p) {
  V8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline V8 Abs(V8 v) {
  return std::bit_cast<V8>(std::bit_cast<I8>(v) & 0x7fffffff);
}
// std::min(a, t): t only if strictly smaller.
inline V8 Min(V8 a, V8 t) { return t < a ? t : a; }
// The smallest of the 8 lanes, in every lane.
inline V8 LaneMin(V8 v) {
  v = Min(v, __builtin_shuffle(v, I8{4, 5, 6, 7, 0, 1, 2, 3}));
  v = Min(v, __builtin_shuffle(v, I8{2, 3, 0, 1, 6, 7, 4, 5}));
  return Min(v, __builtin_shuffle(v, I8{1, 0, 3, 2, 5, 4, 7, 6}));
}

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
  int operator()(int v) const {
    return table_[static_cast<size_t>(v + margin_)];
  }

 private:
  int margin_;
  std::vector<int> table_;
};

// One view's inputs as planes (structure of arrays), plus the guide
// statistics that every disparity reuses.
struct ViewPlanes {
  int w = 0, h = 0, nc = 0;
  std::vector<cv::Mat> own;  // matching image, nc planes
  cv::Mat own_grad;
  // The other view with `pad` border values on each side, mirrored for the
  // left view, so that the partners of x at disparities db .. db + 7 are
  // the 8 floats from column PartnerBase(x, db).
  std::vector<cv::Mat> partner;
  cv::Mat partner_grad;
  int pad = 0;
  bool left = true;
  std::vector<cv::Mat> guide;  // own - kGuideCentre
  std::vector<cv::Mat> mean;   // box means of the guide planes
  std::vector<cv::Mat>
      inv;  // (Sigma + eps)^-1: 1 plane, or 6 (rr rg rb gg gb bb)

  int PartnerBase(int x, int db) const {
    return left ? w + pad - 1 - x + db : pad + x + db;
  }
};

constexpr float kGuideCentre = 0.5f;

cv::Mat BoxMean(const cv::Mat& m, int r) {
  cv::Mat out;
  cv::boxFilter(m, out, CV_32F, cv::Size(2 * r + 1, 2 * r + 1),
                cv::Point(-1, -1), /*normalize=*/true, cv::BORDER_REFLECT);
  return out;
}

cv::Mat PaddedPartner(const cv::Mat& plane, int pad, bool mirror) {
  cv::Mat out;
  cv::copyMakeBorder(plane, out, 0, 0, pad, pad, cv::BORDER_CONSTANT,
                     cv::Scalar(kBorderValue));
  if (mirror) cv::flip(out, out, 1);
  return out;
}

// Planes for matching `view` at disparities [d0, d1].
ViewPlanes MakeViewPlanes(const MatchingImages& m, const StereoOptions& o,
                          View view, int d0, int d1) {
  ViewPlanes v;
  v.left = view == View::kLeft;
  const cv::Mat& own = v.left ? m.left : m.right;
  v.w = own.cols;
  v.h = own.rows;
  v.nc = own.channels();
  cv::split(own, v.own);
  v.own_grad = v.left ? m.left_grad : m.right_grad;
  // Lanes run up to 7 past the block's first disparity.
  v.pad = std::max(std::abs(d0), std::abs(d1)) + kLanes;
  std::vector<cv::Mat> other;
  cv::split(v.left ? m.right : m.left, other);
  for (const cv::Mat& p : other) {
    v.partner.push_back(PaddedPartner(p, v.pad, v.left));
  }
  v.partner_grad =
      PaddedPartner(v.left ? m.right_grad : m.left_grad, v.pad, v.left);
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
    const float* mu[3] = {v.mean[0].ptr<float>(y), v.mean[1].ptr<float>(y),
                          v.mean[2].ptr<float>(y)};
    const float* c[6];
    float* out[6];
    for (int k = 0; k < 6; ++k) {
      c[k] = corr[k].ptr<float>(y);
      out[k] = v.inv[static_cast<size_t>(k)].ptr<float>(y);
    }
    filters::InvertGuideCovarianceRow(mu, c, eps, v.w, out);
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

// Where the WTA of one view goes (full-size CV_32FC1).
struct WtaTarget {
  cv::Mat* best;    // centred filtered cost of the winner
  cv::Mat* label;   // the winner's disparity
  cv::Mat* before;  // cost at label - 1, NaN if none (sub-pixel only)
  cv::Mat* after;   // cost at label + 1, NaN if none (sub-pixel only)
};

template <int NC>
class BlockKernel {
 public:
  static constexpr int kQ = NC + 1;  // quantities per stage: p, I_c p / a_c, b
  // Vertical and horizontal running sums are recomputed from scratch every
  // so many rows and columns, which bounds their float drift.
  static constexpr int kRefreshRows = 64;
  static constexpr int kRefreshCols = 32;

  // Tiles of at most max_rows x max_cols output pixels.
  BlockKernel(const ViewPlanes& v, const StereoOptions& o, int max_rows,
              int max_cols)
      : v_(v),
        r_(o.radius),
        ring_(2 * o.radius + 2),
        rows_(v.h, 2 * o.radius + 2),
        cols_(v.w, 2 * o.radius + 2),
        cp_(MakeCostParams(o, NC)),
        cost_centre_(CostCentre(cp_)),
        inv_area_(1.0f /
                  static_cast<float>((2 * o.radius + 1) * (2 * o.radius + 1))) {
    const size_t wc = static_cast<size_t>(std::min(v.w, max_cols + 4 * r_));
    const size_t ws = static_cast<size_t>(std::min(v.w, max_cols + 2 * r_));
    const size_t ring = static_cast<size_t>(ring_);
    ring1_stride_ = wc;
    ring2_stride_ = ws * kQ;
    ring1_.Reset(ring * wc);
    sum1_.Reset(wc * kQ);
    ring2_.Reset(ring * ws * kQ);
    sum2_.Reset(ws * kQ);
    col1_.resize(ws + static_cast<size_t>(2 * r_));
    col2_.resize(static_cast<size_t>(max_cols + 2 * r_));
    prev_last_.resize(static_cast<size_t>(max_rows) *
                      static_cast<size_t>(max_cols));
  }

  // Disparities [d0, d1] for output rows [y0, y1), columns [x0, x1).
  void Run(int y0, int y1, int x0, int x1, int d0, int d1, bool subpixel,
           const WtaTarget& t) {
    ox0_ = x0;
    ox1_ = x1;
    sx0_ = std::max(0, x0 - r_);
    sx1_ = std::min(v_.w, x1 + r_);
    cx0_ = std::max(0, sx0_ - r_);
    cx1_ = std::min(v_.w, sx1_ + r_);
    // Virtual columns of the two horizontal windows -> buffer columns.
    for (int c = sx0_ - r_; c < sx1_ + r_; ++c) {
      col1_[static_cast<size_t>(c - sx0_ + r_)] = cols_(c) - cx0_;
    }
    for (int c = ox0_ - r_; c < ox1_ + r_; ++c) {
      col2_[static_cast<size_t>(c - ox0_ + r_)] = cols_(c) - sx0_;
    }
    const int s0 = std::max(0, y0 - r_);
    const int s1 = std::min(v_.h, y1 + r_);
    for (int db = d0; db <= d1; db += kLanes) {
      const int lanes = std::min(kLanes, d1 - db + 1);
      int next_cost = std::max(0, s0 - r_);
      int next_out = y0;
      for (int i = s0; i < s1; ++i) {
        for (const int need = std::min(v_.h - 1, i + r_); next_cost <= need;
             ++next_cost) {
          CostRow(db, next_cost);
        }
        Stage1Row(i, (i - s0) % kRefreshRows == 0);
        for (; next_out < y1 && std::min(v_.h - 1, next_out + r_) <= i;
             ++next_out) {
          const bool refresh = (next_out - y0) % kRefreshRows == 0;
          OutputRow(next_out, y0, db, db == d0, lanes, subpixel, refresh, t);
        }
      }
    }
  }

 private:
  // Cost row j (real row; ring slot j % ring), columns from cx0_.
  V8* Ring1(int j) {
    return ring1_.data() + static_cast<size_t>(j % ring_) * ring1_stride_;
  }
  // Stage-1 row i: [column from sx0_][quantity].
  V8* Ring2(int i) {
    return ring2_.data() + static_cast<size_t>(i % ring_) * ring2_stride_;
  }
  const float* Guide(int c, int row) const {
    return v_.guide[static_cast<size_t>(c)].ptr<float>(row);
  }

  // Cost minus the centre at real row j, disparities db .. db + 7, columns
  // [cx0_, cx1_); the same arithmetic as CostRowRange.
  void CostRow(int db, int j) {
    const float* own[NC];
    const float* par[NC];
    for (int c = 0; c < NC; ++c) {
      own[c] = v_.own[static_cast<size_t>(c)].ptr<float>(j);
      par[c] = v_.partner[static_cast<size_t>(c)].ptr<float>(j);
    }
    const float* ga = v_.own_grad.ptr<float>(j);
    const float* gb = v_.partner_grad.ptr<float>(j);
    const V8 alpha = Splat(cp_.alpha), beta = Splat(cp_.beta);
    const V8 t1 = Splat(cp_.t1), t2 = Splat(cp_.t2);
    const V8 centre = Splat(cost_centre_);
    V8* __restrict out = Ring1(j) - cx0_;
    for (int x = cx0_; x < cx1_; ++x) {
      const int px = v_.PartnerBase(x, db);
      V8 cd = Abs(Splat(own[0][x]) - Load(par[0] + px));
      if constexpr (NC == 3) {
        cd = (cd + Abs(Splat(own[1][x]) - Load(par[1] + px)) +
              Abs(Splat(own[2][x]) - Load(par[2] + px))) *
             cp_.inv_nc;
      }
      const V8 gd = Abs(Splat(ga[x]) - Load(gb + px));
      out[x] = (alpha * Min(cd, t1) + beta * Min(gd, t2)) - centre;
    }
  }

  // Guided-filter coefficients a_c, b of real row i, columns [sx0_, sx1_),
  // into Ring2(i).
  void Stage1Row(int i, bool refresh) {
    const int wc = cx1_ - cx0_;
    V8* __restrict s = sum1_.data();
    // Vertical window sums of p and I_c p over virtual rows [i - r, i + r]:
    // from scratch if `refresh`, else by moving the window of row i - 1.
    if (refresh) {
      std::fill(s, s + wc * kQ, V8{});
      for (int t = -r_; t <= r_; ++t) {
        const int row = rows_(i + t);
        const V8* __restrict p = Ring1(row);
        const float* g[NC];
        for (int c = 0; c < NC; ++c) g[c] = Guide(c, row) + cx0_;
        for (int x = 0; x < wc; ++x) {
          V8* sx = s + x * kQ;
          sx[0] += p[x];
          for (int c = 0; c < NC; ++c) sx[c + 1] += Splat(g[c][x]) * p[x];
        }
      }
    } else {
      const int add = rows_(i + r_);
      const int sub = rows_(i - r_ - 1);
      const V8* __restrict pa = Ring1(add);
      const V8* __restrict ps = Ring1(sub);
      const float* ga[NC];
      const float* gs[NC];
      for (int c = 0; c < NC; ++c) {
        ga[c] = Guide(c, add) + cx0_;
        gs[c] = Guide(c, sub) + cx0_;
      }
      for (int x = 0; x < wc; ++x) {
        V8* sx = s + x * kQ;
        sx[0] += pa[x] - ps[x];
        for (int c = 0; c < NC; ++c) {
          sx[c + 1] += Splat(ga[c][x]) * pa[x] - Splat(gs[c][x]) * ps[x];
        }
      }
    }
    // Horizontal window sums, then a and b.
    const int ws = sx1_ - sx0_;
    const float k = inv_area_;
    const float* m[NC];
    for (int c = 0; c < NC; ++c) {
      m[c] = v_.mean[static_cast<size_t>(c)].ptr<float>(i) + sx0_;
    }
    const float* inv[NC == 3 ? 6 : 1];
    for (int c = 0; c < (NC == 3 ? 6 : 1); ++c) {
      inv[c] = v_.inv[static_cast<size_t>(c)].ptr<float>(i) + sx0_;
    }
    V8* __restrict out = Ring2(i);
    V8 h[kQ] = {};
    for (int x = 0; x < ws; ++x) {
      HorizontalStep(s, col1_.data(), x, h);
      V8* o = out + x * kQ;
      const V8 mp = h[0] * k;
      if constexpr (NC == 3) {
        const V8 c0 = h[1] * k - m[0][x] * mp;
        const V8 c1 = h[2] * k - m[1][x] * mp;
        const V8 c2 = h[3] * k - m[2][x] * mp;
        const V8 e0 = inv[0][x] * c0 + inv[1][x] * c1 + inv[2][x] * c2;
        const V8 e1 = inv[1][x] * c0 + inv[3][x] * c1 + inv[4][x] * c2;
        const V8 e2 = inv[2][x] * c0 + inv[4][x] * c1 + inv[5][x] * c2;
        o[0] = e0;
        o[1] = e1;
        o[2] = e2;
        o[3] = mp - e0 * m[0][x] - e1 * m[1][x] - e2 * m[2][x];
      } else {
        const V8 e0 = (h[1] * k - m[0][x] * mp) * inv[0][x];
        o[0] = e0;
        o[1] = mp - e0 * m[0][x];
      }
    }
  }

  // h = window sums at output column x of rows src[col[x .. x + 2r]]
  // (kQ quantities each): from scratch every kRefreshCols columns, else by
  // moving the window of column x - 1.
  void HorizontalStep(const V8* __restrict src, const int* col, int x,
                      V8* h) const {
    if (x % kRefreshCols == 0) {
      for (int q = 0; q < kQ; ++q) h[q] = V8{};
      for (int k = 0; k <= 2 * r_; ++k) {
        const V8* sk = src + col[x + k] * kQ;
        for (int q = 0; q < kQ; ++q) h[q] += sk[q];
      }
      return;
    }
    const V8* sa = src + col[x + 2 * r_] * kQ;
    const V8* ss = src + col[x - 1] * kQ;
    for (int q = 0; q < kQ; ++q) h[q] += sa[q] - ss[q];
  }

  // Filtered costs of output row y at disparities db .. db + lanes - 1 and
  // the WTA update (strictly better wins: ties keep the smaller disparity).
  void OutputRow(int y, int y0, int db, bool first, int lanes, bool subpixel,
                 bool refresh, const WtaTarget& t) {
    const int n = (sx1_ - sx0_) * kQ;
    V8* __restrict s = sum2_.data();
    if (refresh) {
      std::fill(s, s + n, V8{});
      for (int tt = -r_; tt <= r_; ++tt) {
        const V8* __restrict a = Ring2(rows_(y + tt));
        for (int x = 0; x < n; ++x) s[x] += a[x];
      }
    } else {
      const V8* __restrict a = Ring2(rows_(y + r_));
      const V8* __restrict b = Ring2(rows_(y - r_ - 1));
      for (int x = 0; x < n; ++x) s[x] += a[x] - b[x];
    }
    const int w = ox1_ - ox0_;
    const float* g[NC];
    for (int c = 0; c < NC; ++c) g[c] = Guide(c, y) + ox0_;
    float* best = t.best->ptr<float>(y) + ox0_;
    float* label = t.label->ptr<float>(y) + ox0_;
    float* before = subpixel ? t.before->ptr<float>(y) + ox0_ : nullptr;
    float* after = subpixel ? t.after->ptr<float>(y) + ox0_ : nullptr;
    float* prev = prev_last_.data() + static_cast<size_t>((y - y0) * w);
    const float k = inv_area_;
    // Lanes past the last disparity never win.
    const I8 in_range = I8{0, 1, 2, 3, 4, 5, 6, 7} < lanes;
    const V8 inf = Splat(std::numeric_limits<float>::infinity());
    V8 h[kQ] = {};
    for (int x = 0; x < w; ++x) {
      HorizontalStep(s, col2_.data(), x, h);
      V8 q;
      if constexpr (NC == 3) {
        q = (h[0] * g[0][x] + h[1] * g[1][x] + h[2] * g[2][x] + h[3]) * k;
      } else {
        q = (h[0] * g[0][x] + h[1]) * k;
      }
      const float m = LaneMin(lanes == kLanes ? q : (in_range ? q : inf))[0];
      const bool better = first || m < best[x];
      float qs[kLanes];
      std::memcpy(qs, &q, sizeof qs);
      int win = 0;
      if (better) {
        while (qs[win] != m) ++win;  // the first lane holding the minimum
        best[x] = m;
        label[x] = static_cast<float>(db + win);
      }
      if (!subpixel) continue;
      // The previous block's winner at its last lane gets its right
      // neighbour only now.
      if (!better && label[x] == static_cast<float>(db - 1)) after[x] = qs[0];
      if (better) {
        before[x] = win > 0 ? qs[win - 1] : first ? kNaN : prev[x];
        after[x] = win + 1 < lanes ? qs[win + 1] : kNaN;
      }
      prev[x] = qs[lanes - 1];
    }
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
  size_t ring1_stride_ = 0, ring2_stride_ = 0;
  V8Buffer ring1_;                // [row % ring][x]: p - centre
  V8Buffer ring2_;                // [row % ring][x][quantity]: a_c, b
  V8Buffer sum1_;                 // vertical window sums [x][quantity], stage 1
  V8Buffer sum2_;                 // the same, stage 2
  std::vector<int> col1_, col2_;  // horizontal window columns
  std::vector<float> prev_last_;  // cost at the previous block's last lane
};

// The tiles of RunKernel; each thread takes the next one left (so a thread
// slowed by other work on its core does less of them).
struct TileJob {
  const ViewPlanes* v;
  const StereoOptions* o;
  int strip_rows, tile_cols, tiles_per_row, tiles;
  std::atomic<int>* next;
  int d0, d1;
  bool subpixel;
  const WtaTarget* target;
};

template <int NC>
inline void RunTiles(const TileJob& job) {
  BlockKernel<NC> kernel(*job.v, *job.o, job.strip_rows, job.tile_cols);
  for (int t = job.next->fetch_add(1); t < job.tiles;
       t = job.next->fetch_add(1)) {
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
  // Each tile recomputes a halo of 2r rows and columns per side. Wide tiles
  // measured fastest at 1280x960 (docs/benchmarks.md): narrower ones keep
  // the rings in L2 but recompute more halo. The strip height does not
  // change the rings' size, only the halo share and the load balance.
  constexpr int kStripRows = 128;
  constexpr int kTileCols = 640;
  const int strip = std::min(kStripRows, v.h);
  const int tile = std::min(kTileCols, v.w);
  const int per_row = (v.w + tile - 1) / tile;
  const int tiles = per_row * ((v.h + strip - 1) / strip);
  const int threads = std::min(ThreadCount(o), tiles);
  std::atomic<int> next{0};
  auto run = [&](const cv::Range&) {
    const TileJob job{&v,    &o, strip, tile,     per_row, tiles,
                      &next, d0, d1,    subpixel, &target};
    if constexpr (NC == 3) {
      RunTiles3(job);
    } else {
      RunTiles1(job);
    }
  };
  out.cost_centre = CostCentre(MakeCostParams(o, NC));
  if (threads == 1) {
    run(cv::Range(0, 1));
  } else {
    cv::parallel_for_(cv::Range(0, threads), run, threads);
  }
}

KernelOutput FilteredWta(const MatchingImages& images,
                         const StereoOptions& options, View view, int d0,
                         int d1, bool subpixel) {
  const ViewPlanes v = MakeViewPlanes(images, options, view, d0, d1);
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
  RETURN_IF_ERROR(CheckInput(left, "left image", hdr));
  RETURN_IF_ERROR(CheckInput(right, "right image", hdr));
  if (left.size() != right.size() || left.type() != right.type()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "left and right images differ in size or type (", left.cols, "x",
        left.rows, " vs ", right.cols, "x", right.rows, ")"));
  }
  RETURN_IF_ERROR(CheckOptions(options, left.cols));
  try {
    MatchingImages m;
    if (!hdr) {
      m.left = ToUnitFloat(left);
      m.right = ToUnitFloat(right);
    } else {
      const double scale =
          WhitePoint(left, right, options.hdr_white_percentile);
      if (!(scale > 0)) {
        return absl::InvalidArgumentError("HDR pair is black (zero radiance)");
      }
      left.convertTo(m.left, CV_32F, 1.0 / scale);
      right.convertTo(m.right, CV_32F, 1.0 / scale);
      cv::min(m.left, 1.0, m.left);
      cv::min(m.right, 1.0, m.right);
    }
    ComputeGradients(options.mode, m);
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
  RETURN_IF_ERROR(CheckMatchingImages(images, options));
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
  RETURN_IF_ERROR(CheckMatchingImages(images, options));
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

// Colour-weight table bins of n neighbours (planes p*) seen from colour c:
// the squared distance, summed over the channels in order, times
// lut_scale, capped at kLut.
constexpr int kLut = 4096;
void ColourBins3(const float* c, const float* __restrict p0,
                 const float* __restrict p1, const float* __restrict p2, int n,
                 float lut_scale, int* __restrict bins) {
  for (int i = 0; i < n; ++i) {
    const float t0 = c[0] - p0[i];
    const float t1 = c[1] - p1[i];
    const float t2 = c[2] - p2[i];
    const float dist2 = t0 * t0 + t1 * t1 + t2 * t2;
    bins[i] = std::min(kLut, static_cast<int>(dist2 * lut_scale));
  }
}
void ColourBins1(float c, const float* __restrict p0, int n, float lut_scale,
                 int* __restrict bins) {
  for (int i = 0; i < n; ++i) {
    const float t = c - p0[i];
    bins[i] = std::min(kLut, static_cast<int>(t * t * lut_scale));
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
  // Planar guide, so that the colour distances of a window row vectorise.
  std::vector<cv::Mat> planes;
  cv::split(guide, planes);
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    std::vector<int> bins(static_cast<size_t>(side));
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
        const int xa = std::max(0, x - radius);
        const int n = std::min(w - 1, x + radius) - xa + 1;
        for (int yy = std::max(0, y - radius);
             yy <= std::min(h - 1, y + radius); ++yy) {
          if (nc == 3) {
            ColourBins3(ci, planes[0].ptr<float>(yy) + xa,
                        planes[1].ptr<float>(yy) + xa,
                        planes[2].ptr<float>(yy) + xa, n, lut_scale,
                        bins.data());
          } else {
            ColourBins1(ci[0], planes[0].ptr<float>(yy) + xa, n, lut_scale,
                        bins.data());
          }
          const int* lj = label_img.ptr<int>(yy);
          const float* sw =
              spatial.data() +
              static_cast<size_t>((yy - y + radius) * side + radius);
          for (int i = 0; i < n; ++i) {
            const int xx = xa + i;
            const float wgt =
                sw[xx - x] *
                colour[static_cast<size_t>(bins[static_cast<size_t>(i)])];
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
  ASSIGN_OR_RETURN(MatchingImages images,
                   PrepareMatchingImages(left, right, options));
  try {
    // The right view's WTA is only needed for the check; sub-pixel refinement
    // only for the left view.
    StereoOptions right_options = options;
    right_options.subpixel = false;
    ASSIGN_OR_RETURN(WtaResult wl, ComputeWta(images, options, View::kLeft));
    StereoResult result;
    if (!options.left_right_check) {
      result.raw_left = wl.labels;
      result.consistent = cv::Mat(left.size(), CV_8UC1, cv::Scalar(255));
      result.disparity = wl.disparity.clone();
      return result;
    }
    ASSIGN_OR_RETURN(WtaResult wr,
                     ComputeWta(images, right_options, View::kRight));
    result.consistent = LeftRightCheck(
        wl.labels, wr.labels, static_cast<float>(options.lr_tolerance));
    if (options.gain_compensation) {
      const cv::Scalar gain =
          EstimateRightGain(images, wl.labels, result.consistent,
                            static_cast<float>(options.tau_gradient));
      bool off = false;
      for (int c = 0; c < 4; ++c) off |= std::abs(gain[c] - 1) > kGainTolerance;
      if (off) {
        // The left image (the median's guide) stays as it is.
        MatchingImages scaled;
        scaled.left = images.left;
        cv::multiply(images.right, gain, scaled.right);
        cv::min(scaled.right, 1.0, scaled.right);
        ComputeGradients(options.mode, scaled);
        ASSIGN_OR_RETURN(WtaResult wl2,
                         ComputeWta(scaled, options, View::kLeft));
        ASSIGN_OR_RETURN(WtaResult wr2,
                         ComputeWta(scaled, right_options, View::kRight));
        cv::Mat consistent2 = LeftRightCheck(
            wl2.labels, wr2.labels, static_cast<float>(options.lr_tolerance));
        // Kept only if more pixels pass the check: a gain estimated on the
        // textured matches can misfit a pair whose views differ locally
        // (Fattal's tone mapping on low-texture scenes).
        if (cv::countNonZero(consistent2) >
            cv::countNonZero(result.consistent)) {
          result.right_gain = gain;
          wl = std::move(wl2);
          wr = std::move(wr2);
          result.consistent = consistent2;
        }
      }
    }
    result.raw_left = wl.labels;
    result.raw_right = wr.labels;
    cv::Mat disp = wl.labels.clone();
    if (options.fill) {
      FillScanlines(disp, result.consistent,
                    static_cast<float>(options.min_disparity));
      if (options.weighted_median) {
        disp = WeightedMedian(disp, result.consistent, images.left,
                              options.min_disparity, options.max_disparity,
                              options.median_radius, options.sigma_s,
                              options.sigma_c);
      }
    }
    if (options.subpixel) wl.disparity.copyTo(disp, result.consistent);
    result.disparity = disp;
    return result;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("stereo: ", e.what()));
  }
}

}  // namespace hdrstereo::stereo
