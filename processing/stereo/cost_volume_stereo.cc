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

// Per-thread state of the slice loop.
struct ChunkState {
  cv::Mat best, label, before, after;
  cv::Mat cost, filtered, prev;
  filters::GuidedFilterWorkspace ws;
};

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
  const cv::Mat& a = view == View::kLeft ? images.left : images.right;
  const cv::Mat& b = view == View::kLeft ? images.right : images.left;
  const cv::Mat& ga =
      view == View::kLeft ? images.left_grad : images.right_grad;
  const cv::Mat& gb =
      view == View::kLeft ? images.right_grad : images.left_grad;
  // Partner of x is x + shift.
  const int shift = view == View::kLeft ? -d : d;
  const int w = a.cols;
  const int nc = a.channels();
  const float alpha = static_cast<float>(options.alpha);
  const float beta = 1.0f - alpha;
  const float t1 = static_cast<float>(options.tau_color);
  const float t2 = static_cast<float>(options.tau_gradient);
  const float inv_nc = 1.0f / static_cast<float>(nc);
  // Partner inside the image for x in [x0, x1).
  const int x0 = std::clamp(-shift, 0, w);
  const int x1 = std::clamp(w - shift, 0, w);
  cost.create(a.size(), CV_32FC1);
  for (int y = 0; y < a.rows; ++y) {
    const float* pa = a.ptr<float>(y);
    const float* pb = b.ptr<float>(y);
    const float* pga = ga.ptr<float>(y);
    const float* pgb = gb.ptr<float>(y);
    float* out = cost.ptr<float>(y);
    auto border = [&](int x) {
      float cd = 0;
      for (int c = 0; c < nc; ++c)
        cd += std::abs(pa[x * nc + c] - kBorderValue);
      const float gd = std::abs(pga[x] - kBorderValue);
      out[x] = alpha * std::min(cd * inv_nc, t1) + beta * std::min(gd, t2);
    };
    for (int x = 0; x < x0; ++x) border(x);
    for (int x = x1; x < w; ++x) border(x);
    if (nc == 3) {
      for (int x = x0; x < x1; ++x) {
        const float* p = pa + 3 * x;
        const float* q = pb + 3 * (x + shift);
        const float cd = (std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) +
                          std::abs(p[2] - q[2])) *
                         inv_nc;
        const float gd = std::abs(pga[x] - pgb[x + shift]);
        out[x] = alpha * std::min(cd, t1) + beta * std::min(gd, t2);
      }
    } else {
      for (int x = x0; x < x1; ++x) {
        const float cd = std::abs(pa[x] - pb[x + shift]);
        const float gd = std::abs(pga[x] - pgb[x + shift]);
        out[x] = alpha * std::min(cd, t1) + beta * std::min(gd, t2);
      }
    }
  }
}

absl::StatusOr<WtaResult> ComputeWta(const MatchingImages& images,
                                     const StereoOptions& options, View view) {
  if (images.left.empty() || images.left.size() != images.right.size()) {
    return absl::InvalidArgumentError("matching images missing or mismatched");
  }
  if (absl::Status s = CheckOptions(options, images.left.cols); !s.ok()) {
    return s;
  }
  try {
    const cv::Mat& guide = view == View::kLeft ? images.left : images.right;
    absl::StatusOr<filters::GuidedFilter> gf = filters::GuidedFilter::Create(
        guide, filters::GuidedFilterOptions{options.radius, options.eps, 1});
    if (!gf.ok()) return gf.status();
    const int dmin = options.min_disparity;
    const int dmax = options.max_disparity;
    const int labels = dmax - dmin + 1;
    const int chunks = std::min(ThreadCount(options), labels);
    const bool sub = options.subpixel;
    const cv::Size size = guide.size();
    const int n = size.area();
    std::vector<ChunkState> states(static_cast<size_t>(chunks));
    auto run_chunk = [&](int k) {
      ChunkState& st = states[static_cast<size_t>(k)];
      const int d0 =
          dmin + static_cast<int>(static_cast<int64_t>(labels) * k / chunks);
      const int d1 =
          dmin +
          static_cast<int>(static_cast<int64_t>(labels) * (k + 1) / chunks) - 1;
      st.best.create(size, CV_32FC1);
      st.best.setTo(std::numeric_limits<float>::infinity());
      st.label.create(size, CV_32SC1);
      st.label.setTo(d0);
      if (sub) {
        st.before.create(size, CV_32FC1);
        st.after.create(size, CV_32FC1);
        st.before.setTo(kNaN);
        st.after.setTo(kNaN);
      }
      const int start = sub ? std::max(dmin, d0 - 1) : d0;
      const int end = sub ? std::min(dmax, d1 + 1) : d1;
      bool have_prev = false;
      for (int d = start; d <= end; ++d) {
        ComputeCostSlice(images, options, view, d, st.cost);
        gf->FilterPlane(st.cost, st.filtered, &st.ws);
        const float* q = st.filtered.ptr<float>();
        float* best = st.best.ptr<float>();
        int* label = st.label.ptr<int>();
        if (sub) {
          float* after = st.after.ptr<float>();
          float* before = st.before.ptr<float>();
          const float* prev = st.prev.empty() ? nullptr : st.prev.ptr<float>();
          for (int i = 0; i < n; ++i) {
            if (label[i] == d - 1 &&
                best[i] < std::numeric_limits<float>::infinity()) {
              after[i] = q[i];
            }
          }
          if (d >= d0 && d <= d1) {
            for (int i = 0; i < n; ++i) {
              if (q[i] < best[i]) {
                best[i] = q[i];
                label[i] = d;
                before[i] = have_prev ? prev[i] : kNaN;
                after[i] = kNaN;
              }
            }
          }
          std::swap(st.prev, st.filtered);
          have_prev = true;
        } else {
          for (int i = 0; i < n; ++i) {
            const bool better = q[i] < best[i];
            best[i] = better ? q[i] : best[i];
            label[i] = better ? d : label[i];
          }
        }
      }
    };
    if (chunks == 1) {
      run_chunk(0);
    } else {
      cv::parallel_for_(
          cv::Range(0, chunks),
          [&](const cv::Range& r) {
            for (int k = r.start; k < r.end; ++k) run_chunk(k);
          },
          chunks);
    }
    // Merge the chunks in disparity order (ties: the smaller disparity).
    WtaResult out;
    ChunkState& first = states[0];
    for (size_t k = 1; k < states.size(); ++k) {
      const float* b = states[k].best.ptr<float>();
      const int* l = states[k].label.ptr<int>();
      float* fb = first.best.ptr<float>();
      int* fl = first.label.ptr<int>();
      for (int i = 0; i < n; ++i) {
        if (b[i] < fb[i]) {
          fb[i] = b[i];
          fl[i] = l[i];
          if (sub) {
            first.before.ptr<float>()[i] = states[k].before.ptr<float>()[i];
            first.after.ptr<float>()[i] = states[k].after.ptr<float>()[i];
          }
        }
      }
    }
    first.label.convertTo(out.labels, CV_32F);
    out.cost = first.best;
    if (!sub) {
      out.disparity = out.labels;
      return out;
    }
    out.disparity = out.labels.clone();
    float* disp = out.disparity.ptr<float>();
    const float* c0 = first.best.ptr<float>();
    const float* cm = first.before.ptr<float>();
    const float* cp = first.after.ptr<float>();
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
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    std::vector<float> hist(static_cast<size_t>(labels));
    for (int y = rows.start; y < rows.end; ++y) {
      const uint8_t* v = valid.ptr<uint8_t>(y);
      const float* gi = guide.ptr<float>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < w; ++x) {
        if (v[x]) continue;
        std::fill(hist.begin(), hist.end(), 0.0f);
        float total = 0;
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
            hist[static_cast<size_t>(lj[xx])] += wgt;
            total += wgt;
          }
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
