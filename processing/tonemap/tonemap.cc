// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/tonemap/tonemap.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <numbers>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/filters/fast_bilateral.h"
#include "processing/tonemap/fattal.h"
#include "processing/tonemap/pooled_quantiles.h"

namespace hdrstereo::tonemap {
namespace {

constexpr float kWr = 0.2126f, kWg = 0.7152f, kWb = 0.0722f;
constexpr double kLumFloorFraction = 1e-6;
constexpr float kLn10 = static_cast<float>(std::numbers::ln10);

struct NamedOperator {
  Operator op;
  const char* name;
};
constexpr NamedOperator kOperators[] = {
    {Operator::kReinhard, "reinhard"},
    {Operator::kDurand, "durand"},
    {Operator::kFattal, "fattal"},
    {Operator::kDrago, "drago"},
    {Operator::kGuided, "guided"},
    {Operator::kDomainTransform, "domain-transform"},
    {Operator::kWls, "wls"},
};

absl::Status ValidateRadiance(const cv::Mat& m, absl::string_view what) {
  if (m.empty())
    return absl::InvalidArgumentError(absl::StrCat(what, " is empty"));
  if (m.type() != CV_32FC3 || m.dims != 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, " must be a 2-D CV_32FC3 linear radiance image, got type ",
        m.type()));
  }
  cv::Point bad;
  if (!cv::checkRange(m, /*quiet=*/true, &bad, 0.0, FLT_MAX)) {
    const cv::Vec3f v = m.at<cv::Vec3f>(bad);
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(v[c])) {
        return absl::InvalidArgumentError(absl::StrCat(
            what, " contains NaN or Inf at (", bad.x, ", ", bad.y, ")"));
      }
    }
    return absl::InvalidArgumentError(absl::StrCat(
        what, " contains negative radiance at (", bad.x, ", ", bad.y, ")"));
  }
  return absl::OkStatus();
}

cv::Mat Luminance(const cv::Mat& bgr) {
  cv::Mat lum(bgr.size(), CV_32FC1);
  cv::parallel_for_(cv::Range(0, bgr.rows), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) {
      const float* p = bgr.ptr<float>(y);
      float* o = lum.ptr<float>(y);
      for (int x = 0; x < bgr.cols; ++x) {
        o[x] = kWb * p[3 * x] + kWg * p[3 * x + 1] + kWr * p[3 * x + 2];
      }
    }
  });
  return lum;
}

// Per-row display luminance: fn(y, lum_row (floored), ld_row, n).
template <typename LdFn>
cv::Mat EncodeView(const cv::Mat& bgr, const cv::Mat& lum, float lum_floor,
                   const Params& p, const LdFn& ld_fn) {
  cv::Mat out(bgr.size(), CV_8UC3);
  const float s = static_cast<float>(p.saturation);
  const float inv_gamma = static_cast<float>(1.0 / p.gamma);
  const int w = bgr.cols;
  cv::parallel_for_(cv::Range(0, bgr.rows), [&](const cv::Range& r) {
    std::vector<float> l(w), ld(w), ratio(3 * w);
    for (int y = r.start; y < r.end; ++y) {
      const float* src = bgr.ptr<float>(y);
      const float* lr = lum.ptr<float>(y);
      for (int x = 0; x < w; ++x) l[x] = std::max(lr[x], lum_floor);
      ld_fn(y, l.data(), ld.data(), w);
      for (int x = 0; x < w; ++x) {
        const float inv_l = 1.0f / l[x];
        for (int c = 0; c < 3; ++c) {
          ratio[3 * x + c] = std::max(src[3 * x + c] * inv_l, 1e-7f);
        }
        ld[x] = std::max(ld[x], 1e-30f);
      }
      cv::hal::log32f(ratio.data(), ratio.data(), 3 * w);
      cv::hal::log32f(ld.data(), ld.data(), w);
      for (int x = 0; x < w; ++x) {
        for (int c = 0; c < 3; ++c) {
          ratio[3 * x + c] =
              std::min((s * ratio[3 * x + c] + ld[x]) * inv_gamma, 1.0f);
        }
      }
      cv::hal::exp32f(ratio.data(), ratio.data(), 3 * w);
      uchar* o = out.ptr<uchar>(y);
      for (int k = 0; k < 3 * w; ++k) {
        o[k] = cv::saturate_cast<uchar>(ratio[k] * 255.0f);
      }
    }
  });
  return out;
}

struct PairLuminance {
  std::vector<cv::Mat> lum;  // raw luminance per view
  float floor = 0.0f;        // 1e-6 times the pair's maximum
  double max = 0.0;          // pair's maximum (>= floor)
};

absl::StatusOr<PairLuminance> ComputeLuminance(
    const std::vector<cv::Mat>& views) {
  PairLuminance pl;
  for (const cv::Mat& v : views) {
    pl.lum.push_back(Luminance(v));
    double mx = 0;
    cv::minMaxLoc(pl.lum.back(), nullptr, &mx);
    pl.max = std::max(pl.max, mx);
  }
  if (!(pl.max > 0)) {
    return absl::InvalidArgumentError(
        "radiance is zero everywhere (no luminance to map)");
  }
  pl.floor = static_cast<float>(pl.max * kLumFloorFraction);
  return pl;
}

// Mean of ln(max(lum, floor)) over all views.
double MeanLogLuminance(const PairLuminance& pl) {
  double sum = 0.0;
  double count = 0.0;
  for (const cv::Mat& lum : pl.lum) {
    std::vector<float> buf(lum.cols);
    for (int y = 0; y < lum.rows; ++y) {
      const float* p = lum.ptr<float>(y);
      for (int x = 0; x < lum.cols; ++x) buf[x] = std::max(p[x], pl.floor);
      cv::hal::log32f(buf.data(), buf.data(), lum.cols);
      float row = 0.0f;
      for (int x = 0; x < lum.cols; ++x) row += buf[x];
      sum += row;
    }
    count += static_cast<double>(lum.total());
  }
  return sum / count;
}

std::vector<cv::Mat> ToneMapReinhard(const std::vector<cv::Mat>& views,
                                     const PairLuminance& pl, const Params& p) {
  const double log_avg = std::exp(MeanLogLuminance(pl));
  const float scale = static_cast<float>(p.reinhard.key / log_avg);
  const double white = p.reinhard.white > 0 ? p.reinhard.white : pl.max * scale;
  const float inv_white2 = static_cast<float>(1.0 / (white * white));
  std::vector<cv::Mat> out;
  for (size_t v = 0; v < views.size(); ++v) {
    out.push_back(EncodeView(views[v], pl.lum[v], pl.floor, p,
                             [&](int, const float* l, float* ld, int n) {
                               for (int x = 0; x < n; ++x) {
                                 const float ls = l[x] * scale;
                                 ld[x] = ls * (1.0f + ls * inv_white2) /
                                         (1.0f + ls);
                               }
                             }));
  }
  return out;
}

std::vector<cv::Mat> ToneMapDrago(const std::vector<cv::Mat>& views,
                                  const PairLuminance& pl, const Params& p) {
  const double lwa = std::exp(MeanLogLuminance(pl));
  const float inv_lwa = static_cast<float>(1.0 / lwa);
  const double lw_max = pl.max / lwa;
  const float inv_lw_max = static_cast<float>(1.0 / lw_max);
  const float k = static_cast<float>(std::log(p.drago.bias) / std::log(0.5));
  const float front =
      static_cast<float>((p.drago.ld_max / 100.0) / std::log10(lw_max + 1.0));
  std::vector<cv::Mat> out;
  for (size_t v = 0; v < views.size(); ++v) {
    out.push_back(EncodeView(views[v], pl.lum[v], pl.floor, p,
                             [&](int, const float* l, float* ld, int n) {
                               thread_local std::vector<float> num, den;
                               num.resize(n);
                               den.resize(n);
                               for (int x = 0; x < n; ++x) {
                                 const float lw = l[x] * inv_lwa;
                                 num[x] = lw + 1.0f;
                                 den[x] = lw * inv_lw_max;
                               }
                               cv::hal::log32f(den.data(), den.data(), n);
                               for (int x = 0; x < n; ++x) den[x] *= k;
                               cv::hal::exp32f(den.data(), den.data(), n);
                               for (int x = 0; x < n; ++x)
                                 den[x] = 2.0f + 8.0f * den[x];
                               cv::hal::log32f(num.data(), num.data(), n);
                               cv::hal::log32f(den.data(), den.data(), n);
                               for (int x = 0; x < n; ++x)
                                 ld[x] = front * num[x] / den[x];
                             }));
  }
  return out;
}

// Stretches the pooled display luminances linearly (clip_low -> 0,
// clip_high -> 1) and encodes every view.
std::vector<cv::Mat> StretchAndEncode(const std::vector<cv::Mat>& views,
                                      const PairLuminance& pl,
                                      const std::vector<cv::Mat>& ld,
                                      const Params& p) {
  auto [lo, hi] = PooledQuantiles(ld, p.clip_low, 1.0 - p.clip_high);
  // A (nearly) uniform image has no range to stretch: map its level to white
  // instead of amplifying rounding noise.
  if (!(hi - lo > 1e-3f * hi)) {
    lo = 0.0f;
    hi = std::max(hi, 1e-30f);
  }
  const float inv = 1.0f / (hi - lo);
  std::vector<cv::Mat> out;
  for (size_t v = 0; v < views.size(); ++v) {
    const cv::Mat& m = ld[v];
    out.push_back(EncodeView(views[v], pl.lum[v], pl.floor, p,
                             [&](int y, const float*, float* o, int n) {
                               const float* row = m.ptr<float>(y);
                               for (int x = 0; x < n; ++x) {
                                 o[x] = (row[x] - lo) * inv;
                               }
                             }));
  }
  return out;
}

// log10 of the floored luminance.
cv::Mat Log10Luminance(const cv::Mat& lum, float floor) {
  cv::Mat out(lum.size(), CV_32FC1);
  cv::parallel_for_(cv::Range(0, lum.rows), [&](const cv::Range& r) {
    for (int y = r.start; y < r.end; ++y) {
      const float* p = lum.ptr<float>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < lum.cols; ++x) o[x] = std::max(p[x], floor);
      cv::hal::log32f(o, o, lum.cols);
      for (int x = 0; x < lum.cols; ++x) o[x] *= 1.0f / kLn10;
    }
  });
  return out;
}

absl::StatusOr<cv::Mat> BaseLayer(Operator op, const cv::Mat& log10_lum,
                                  const Params& p) {
  if (op == Operator::kDurand) {
    filters::FastBilateralOptions o;
    o.sigma_s =
        p.durand.sigma_s_fraction * std::max(log10_lum.cols, log10_lum.rows);
    o.sigma_r = p.durand.sigma_r;
    return filters::FastBilateralFilter(log10_lum, o);
  }
  // The other filters work on the same log10 luminance (see tonemap.h).
  switch (op) {
    case Operator::kGuided:
      return filters::ApplyGuidedFilter(log10_lum, log10_lum, p.guided);
    case Operator::kDomainTransform:
      return filters::DomainTransformFilter(log10_lum, cv::Mat(),
                                            p.domain_transform);
    case Operator::kWls:
      return filters::WlsFilter(log10_lum, cv::Mat(), p.wls);
    default:
      return absl::InternalError("not a base/detail operator");
  }
}

absl::StatusOr<std::vector<cv::Mat>> ToneMapBaseDetail(
    const std::vector<cv::Mat>& views, const PairLuminance& pl, Operator op,
    const Params& p) {
  std::vector<cv::Mat> log_lum, base;
  for (const cv::Mat& lum : pl.lum) {
    log_lum.push_back(Log10Luminance(lum, pl.floor));
  }
  double b_lo = DBL_MAX, b_hi = -DBL_MAX;
  for (const cv::Mat& l : log_lum) {
    ASSIGN_OR_RETURN(cv::Mat b, BaseLayer(op, l, p));
    double a, c;
    cv::minMaxLoc(b, &a, &c);
    b_lo = std::min(b_lo, a);
    b_hi = std::max(b_hi, c);
    base.push_back(b);
  }
  const float compression =
      b_hi - b_lo > 1e-6
          ? static_cast<float>(std::log10(p.base_contrast) / (b_hi - b_lo))
          : 1.0f;
  const float top = static_cast<float>(b_hi);
  std::vector<cv::Mat> ld;
  for (size_t v = 0; v < views.size(); ++v) {
    cv::Mat d(log_lum[v].size(), CV_32FC1);
    cv::parallel_for_(cv::Range(0, d.rows), [&](const cv::Range& r) {
      for (int y = r.start; y < r.end; ++y) {
        const float* l = log_lum[v].ptr<float>(y);
        const float* b = base[v].ptr<float>(y);
        float* o = d.ptr<float>(y);
        for (int x = 0; x < d.cols; ++x) {
          o[x] = (compression * (b[x] - top) + (l[x] - b[x])) * kLn10;
        }
        cv::hal::exp32f(o, o, d.cols);
      }
    });
    ld.push_back(d);
  }
  return StretchAndEncode(views, pl, ld, p);
}

absl::StatusOr<std::vector<cv::Mat>> ToneMapFattal(
    const std::vector<cv::Mat>& views, const PairLuminance& pl,
    const Params& p) {
  std::vector<cv::Mat> log_lum;
  for (const cv::Mat& lum : pl.lum) {
    cv::Mat l = Log10Luminance(lum, pl.floor);
    log_lum.push_back(l * kLn10);
  }
  ASSIGN_OR_RETURN(std::vector<cv::Mat> compressed,
                   FattalCompress(log_lum, p.fattal));
  std::vector<cv::Mat> ld;
  for (cv::Mat& c : compressed) {
    cv::Mat e;
    cv::exp(c, e);
    ld.push_back(e);
  }
  return StretchAndEncode(views, pl, ld, p);
}

}  // namespace

absl::StatusOr<Operator> OperatorFromName(absl::string_view name) {
  for (const NamedOperator& n : kOperators) {
    if (name == n.name) return n.op;
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown tone-mapping operator '", name,
      "'; expected reinhard, durand, fattal, drago, guided, domain-transform "
      "or wls"));
}

std::string OperatorName(Operator op) {
  for (const NamedOperator& n : kOperators) {
    if (n.op == op) return n.name;
  }
  return "unknown";
}

std::vector<Operator> AllOperators() {
  std::vector<Operator> all;
  for (const NamedOperator& n : kOperators) all.push_back(n.op);
  return all;
}

absl::StatusOr<std::vector<cv::Mat>> ToneMapViews(
    const std::vector<cv::Mat>& radiance, Operator op, const Params& params) {
  if (radiance.empty()) return absl::InvalidArgumentError("no views given");
  for (size_t v = 0; v < radiance.size(); ++v) {
    const std::string what = radiance.size() == 1
                                 ? std::string("radiance")
                                 : absl::StrCat("radiance of view ", v);
    RETURN_IF_ERROR(ValidateRadiance(radiance[v], what));
  }
  if (absl::Status s = params.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("tone mapping: ", s.message()));
  }
  try {
    ASSIGN_OR_RETURN(PairLuminance pl, ComputeLuminance(radiance));
    switch (op) {
      case Operator::kReinhard:
        return ToneMapReinhard(radiance, pl, params);
      case Operator::kDrago:
        return ToneMapDrago(radiance, pl, params);
      case Operator::kFattal:
        return ToneMapFattal(radiance, pl, params);
      case Operator::kDurand:
      case Operator::kGuided:
      case Operator::kDomainTransform:
      case Operator::kWls:
        return ToneMapBaseDetail(radiance, pl, op, params);
    }
    return absl::InvalidArgumentError("unknown tone-mapping operator");
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("tone mapping (", OperatorName(op), "): ", e.what()));
  }
}

absl::StatusOr<cv::Mat> ToneMap(const cv::Mat& radiance, Operator op,
                                const Params& params) {
  ASSIGN_OR_RETURN(std::vector<cv::Mat> out,
                   ToneMapViews({radiance}, op, params));
  return std::move(out.front());
}

absl::StatusOr<std::pair<cv::Mat, cv::Mat>> ToneMapPair(const cv::Mat& left,
                                                        const cv::Mat& right,
                                                        Operator op,
                                                        const Params& params) {
  ASSIGN_OR_RETURN(std::vector<cv::Mat> out,
                   ToneMapViews({left, right}, op, params));
  return std::make_pair(std::move((out)[0]), std::move((out)[1]));
}

}  // namespace hdrstereo::tonemap
