// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/mesopic/shin_model.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hdrstereo::mesopic {

// Fitting functions alpha(E), beta(E), l(E), a(E), m(E), b(E).
//
// SOURCE: derived by us, NOT copied from Shin et al. (2004) Table 1, which we
// could not obtain (the thesis cites it but does not reproduce it). The
// derivation, also in docs/mesopic.md:
//  * Rod share w(E) of the achromatic response of white: 0 at and above
//    5 cd/m^2, 1 at 0.005 cd/m^2 (CIE 191:2010 mesopic limits), linear in
//    log luminance, with E = pi * L; capped at 0.95 so that alpha > 0 (Eq.
//    6.4 divides by alpha).
//  * alpha = 1 - w and beta = w / K'_w, so that white keeps A = 1 at every
//    level (lightness loss is left to the tone curve) while coloured stimuli
//    shift with their rod/cone ratio: blues gain, reds lose (Purkinje).
//  * l (red/green gain) and m (blue/yellow gain) fall with illuminance and
//    level off, following Shin, Yaguchi & Shioiri (Opt. Rev. 11, 265, 2004):
//    chroma decreases continuously down to about 0.1-1 lx and is roughly
//    constant below.
//  * a = -0.03 w and b = -0.05 w: a small rod input towards green and blue
//    (rods feed the L, M and S pathways; Cao et al. 2008), giving the
//    blue-green hue shift of mesopic vision.
// At and above 100 lx every rod term is exactly zero (photopic model).
const std::array<FittingNode, kFittingNodes> kShinFittingTable = {{
    //  E [lx]  alpha     beta        l     a           m     b
    {0.01, {0.05, 0.0121173, 0.40, -0.0285, 0.45, -0.0475}},
    {0.1, {0.26794, 0.0093375, 0.40, -0.0219618, 0.45, -0.0366030}},
    {1.0, {0.60129, 0.0050856, 0.55, -0.0119613, 0.50, -0.0199355}},
    {10.0, {0.934627, 0.00083384, 0.85, -0.0019612, 0.80, -0.0032687}},
    {100.0, {1.0, 0.0, 1.0, 0.0, 1.0, 0.0}},
    {1000.0, {1.0, 0.0, 1.0, 0.0, 1.0, 0.0}},
}};

namespace {

// Larson et al. 1997 scotopic approximation at one primary (XYZ column).
double LarsonScotopic(double x, double y, double z) {
  return y * (1.33 * (1.0 + (y + z) / x) - 1.68);
}

FittingOptions Lerp(const FittingOptions& p, const FittingOptions& q,
                    double t) {
  auto mix = [t](double u, double v) { return u + (v - u) * t; };
  return {mix(p.alpha, q.alpha), mix(p.beta, q.beta), mix(p.l, q.l),
          mix(p.a, q.a),         mix(p.m, q.m),       mix(p.b, q.b)};
}

}  // namespace

Vec3 ScotopicWeights() {
  static const Vec3 weights = [] {
    Vec3 w;
    double sum = 0.0;
    for (int c = 0; c < 3; ++c) {
      w[c] = LarsonScotopic(kRgbToXyz[0][c], kRgbToXyz[1][c], kRgbToXyz[2][c]);
      sum += w[c];
    }
    for (double& v : w) v /= sum;
    return w;
  }();
  return weights;
}

double ScotopicLuminance(const Vec3& rgb) {
  const Vec3 w = ScotopicWeights();
  return w[0] * rgb[0] + w[1] * rgb[1] + w[2] * rgb[2];
}

FittingOptions FittingAt(double lux) {
  const auto& t = kShinFittingTable;
  if (!(lux > t.front().lux)) return t.front().params;
  if (lux >= t.back().lux) return t.back().params;
  const double x = std::log10(lux);
  for (int i = 0; i + 1 < kFittingNodes; ++i) {
    if (lux <= t[i + 1].lux) {
      const double x0 = std::log10(t[i].lux);
      const double x1 = std::log10(t[i + 1].lux);
      return Lerp(t[i].params, t[i + 1].params, (x - x0) / (x1 - x0));
    }
  }
  return t.back().params;
}

double LuxFromWhiteLuminance(double cd_per_m2) {
  return std::numbers::pi * cd_per_m2;
}

double RodWeight(double lux) { return 1.0 - FittingAt(lux).alpha; }

Mat3 Multiply(const Mat3& a, const Mat3& b) {
  Mat3 r{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) r[i][j] += a[i][k] * b[k][j];
    }
  }
  return r;
}

Vec3 Apply(const Mat3& m, const Vec3& v) {
  Vec3 r{};
  for (int i = 0; i < 3; ++i) {
    r[i] = m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2];
  }
  return r;
}

Mat3 Inverse(const Mat3& m) {
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  const double s = 1.0 / det;
  Mat3 r;
  r[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * s;
  r[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * s;
  r[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * s;
  r[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * s;
  r[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * s;
  r[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * s;
  r[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * s;
  r[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * s;
  r[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * s;
  return r;
}

namespace {

Mat3 RgbToLms() { return Multiply(kXyzToLms, kRgbToXyz); }

// L_pw + M_pw of white (1,1,1).
double WhiteLPlusM() {
  const Vec3 w = Apply(RgbToLms(), {1.0, 1.0, 1.0});
  return w[0] + w[1];
}

// [L+M, L-2M, L+M-S] = kOpp * LMS (Eq. 6.5's matrix).
constexpr Mat3 kOpp = {{{1.0, 1.0, 0.0}, {1.0, -2.0, 0.0}, {1.0, 1.0, -1.0}}};

}  // namespace

Opponent ShinForward(const Vec3& rgb, double lux) {
  const FittingOptions f = FittingAt(lux);
  const Vec3 lms = Apply(RgbToLms(), rgb);
  const double y_scot = std::max(ScotopicLuminance(rgb), 0.0);  // Y'/Y'_w
  Opponent o;
  o.achromatic = f.alpha * kKw * (lms[0] + lms[1]) / WhiteLPlusM() +
                 f.beta * kKwPrime * std::pow(y_scot, kGamma);
  o.red_green = f.l * (lms[0] - 2.0 * lms[1]) + f.a * y_scot;
  o.blue_yellow = f.m * (lms[0] + lms[1] - lms[2]) + f.b * y_scot;
  return o;
}

Vec3 PerceivedXyz(const Opponent& opp) {
  return Apply(kOppToXyz, {opp.achromatic, opp.red_green, opp.blue_yellow});
}

Vec3 ShinInverse(const Opponent& opp, double lux) {
  const FittingOptions f = FittingAt(lux);
  const double lmw = WhiteLPlusM();
  // rgb = G * [P, Q, R] with P = L+M, Q = L-2M, R = L+M-S; Y' = c . [P,Q,R].
  const Mat3 g = Multiply(Inverse(RgbToLms()), Inverse(kOpp));
  const Vec3 w = ScotopicWeights();
  Vec3 c{};
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) c[j] += w[i] * g[i][j];
  }
  // P = p0 - p1 v, Q = q0 - q1 s, R = r0 - r1 s with s = Y', v = s^gamma.
  const double p0 = lmw / (f.alpha * kKw) * opp.achromatic;
  const double p1 = lmw / (f.alpha * kKw) * f.beta * kKwPrime;
  const double q0 = opp.red_green / f.l, q1 = f.a / f.l;
  const double r0 = opp.blue_yellow / f.m, r1 = f.b / f.m;
  // s = c.[P,Q,R]  <=>  k1 s + k2 s^gamma = d.
  const double k1 = 1.0 + c[1] * q1 + c[2] * r1;
  const double k2 = c[0] * p1;
  const double d = std::max(c[0] * p0 + c[1] * q0 + c[2] * r0, 0.0);
  double s;
  if (k2 <= 0.0) {
    s = d / k1;
  } else {
    // In v = s^gamma the function k1 v^(1/gamma) + k2 v - d is convex and
    // increasing: Newton from an upper bound converges monotonically.
    double v = std::min(d / k2, std::pow(d / k1, kGamma));
    for (int it = 0; it < 50 && v > 0.0; ++it) {
      const double vp = std::pow(v, 1.0 / kGamma - 1.0);
      const double fv = k1 * vp * v + k2 * v - d;
      const double step = fv / (k1 / kGamma * vp + k2);
      v -= step;
      if (std::abs(step) <= 1e-15 * (1.0 + v)) break;
    }
    s = std::pow(std::max(v, 0.0), 1.0 / kGamma);
  }
  const Vec3 pqr = {p0 - p1 * std::pow(s, kGamma), q0 - q1 * s, r0 - r1 * s};
  return Apply(g, pqr);
}

}  // namespace hdrstereo::mesopic
