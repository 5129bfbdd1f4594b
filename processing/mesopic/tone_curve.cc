// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/mesopic/tone_curve.h"

#include <algorithm>
#include <cmath>

namespace hdrstereo::mesopic {

double ContrastThreshold(double cd) {
  return 0.01 * (1.0 + 1.0 / std::sqrt(std::max(cd, 1e-6)));
}

namespace {
double G(double cd) { return std::log10(1.0 + ContrastThreshold(cd)); }
}  // namespace

ToneCurve ToneCurve::Build(std::span<const float> source_cd,
                           double source_peak_cd, double display_cd,
                           double display_black_cd) {
  // Defensive defaults: callers should pass positive finite luminances.
  auto usable = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!usable(source_peak_cd)) source_peak_cd = 1.0;
  if (!usable(display_cd)) display_cd = 1.0;
  if (!usable(display_black_cd) || display_black_cd >= display_cd) {
    display_black_cd = display_cd * 1e-3;
  }
  ToneCurve t;
  const double hi = std::log10(source_peak_cd);
  // Source range: down to the darkest sample, at most 6 decades.
  double lo = hi - 6.0;
  double darkest = source_peak_cd;
  for (float v : source_cd) {
    if (v > 0.0f && v < darkest) darkest = v;  // NaN compares false
  }
  lo = std::max(lo, std::log10(darkest));
  if (hi - lo < 1e-3) lo = hi - 1e-3;
  t.lo_ = lo;
  t.step_ = (hi - lo) / kBins;
  t.black_ = std::log10(display_black_cd);

  std::vector<double> hist(kBins, 0.0);
  for (float v : source_cd) {
    if (!(v > 0.0f) || !std::isfinite(v)) continue;
    const int bin = static_cast<int>((std::log10(v) - lo) / t.step_);
    hist[std::clamp(bin, 0, kBins - 1)] += 1.0;
  }

  const double top = std::log10(display_cd);
  const double available = top - t.black_;
  // Start from plain scaling, then refine target levels (thresholds depend
  // on the target luminance) for a few rounds.
  std::vector<double> y(kBins + 1);
  for (int j = 0; j <= kBins; ++j) y[j] = top - (hi - (lo + j * t.step_));
  std::vector<double> k(kBins);
  for (int round = 0; round < 3; ++round) {
    double occupied = 0.0, empty = 0.0;
    for (int i = 0; i < kBins; ++i) {
      const double ls = std::pow(10.0, lo + (i + 0.5) * t.step_);
      const double lt = std::pow(10.0, 0.5 * (y[i] + y[i + 1]));
      if (hist[i] > 0.0) {
        k[i] = std::clamp(1.0 + (G(lt) - G(ls)) / kReferenceContrast, 1.0, 3.0);
        occupied += k[i] * t.step_;
      } else {
        k[i] = 1.0;
        empty += t.step_;
      }
    }
    if (occupied + empty > available) {
      // Compress empty bins first, then everything uniformly.
      const double e =
          empty > 0.0 ? std::clamp((available - occupied) / empty, 0.0, 1.0)
                      : 0.0;
      const double f = occupied > 0.0
                           ? std::min(1.0, (available - e * empty) / occupied)
                           : 1.0;
      for (int i = 0; i < kBins; ++i) k[i] *= hist[i] > 0.0 ? f : e;
    }
    y[kBins] = top;
    for (int i = kBins - 1; i >= 0; --i) y[i] = y[i + 1] - k[i] * t.step_;
  }
  for (double& v : y) v = std::max(v, t.black_);
  t.y_ = std::move(y);
  return t;
}

double ToneCurve::Map(double cd) const {
  if (!(cd > 0.0)) return 0.0;
  const double u =
      std::min((std::log10(cd) - lo_) / step_, static_cast<double>(kBins));
  // Below the sampled range the curve continues with slope 1.
  if (u < 0.0) return std::pow(10.0, std::max(y_[0] + u * step_, black_));
  const int j = std::min(static_cast<int>(u), kBins - 1);
  const double f = u - j;
  return std::pow(10.0, y_[j] + (y_[j + 1] - y_[j]) * f);
}

}  // namespace hdrstereo::mesopic
