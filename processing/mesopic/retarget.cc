// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/mesopic/retarget.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "opencv2/core/utility.hpp"
#include "processing/base/status_macros.h"
#include "processing/mesopic/fast_math.h"
#include "processing/mesopic/shin_model.h"
#include "processing/mesopic/tone_curve.h"

namespace hdrstereo::mesopic {

absl::StatusOr<Method> MethodFromName(absl::string_view name) {
  const std::string n = absl::AsciiStrToLower(name);
  if (n == "none") return Method::kNone;
  if (n == "shin") return Method::kShin;
  if (n == "wanat-saturation" || n == "wanat_saturation") {
    return Method::kWanatSaturation;
  }
  if (n == "rods") return Method::kRods;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown mesopic method '", name,
                   "'; expected none, shin, wanat-saturation or rods"));
}

std::string MethodName(Method method) {
  switch (method) {
    case Method::kNone:
      return "none";
    case Method::kShin:
      return "shin";
    case Method::kWanatSaturation:
      return "wanat-saturation";
    case Method::kRods:
      return "rods";
  }
  return "unknown";
}

namespace {

using internal::FastExp2;
using internal::FastLog2;
using internal::FastPow;

constexpr float kLumR = 0.2126f, kLumG = 0.7152f, kLumB = 0.0722f;
constexpr double kLog10Of2 = 0.30102999566398120;
constexpr double kLog2Of10 = 3.32192809488736235;
constexpr int kEncodeLutSize = 16384;
// Float input is clamped to [0, kMaxInput] x source white; luminances are
// limited to kMaxLuminance cd/m^2 so that products stay finite in float.
constexpr float kMaxInput = 1e9f;
constexpr double kMaxLuminance = 1e9;
// The inverse model's scotopic luminance s solves k1 s + k2 s^gamma = d, a
// frame-constant monotone function of d. It is tabulated as log2 s over
// log2 d (kSolveNodes nodes on [kSolveLo, kSolveHi], asymptotic slopes
// outside), interpolated linearly and polished with one Newton step.
constexpr int kSolveNodes = 1025;
constexpr double kSolveLo = -60.0, kSolveHi = 40.0;

// Rod gains of the rod-contribution model at full rod vision (kappa_1 for L
// and M, kappa_2 for S, Eq. 6.11), scaled by the rod weight of the level.
// Assumed values, see docs/mesopic.md.
constexpr double kRodKappa1 = 0.25;
constexpr double kRodKappa2 = 0.40;

double SrgbToLinear(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}
double LinearToSrgb(double v) {
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

// sRGB decode (8-bit -> linear) and encode (linear in [0,1] sampled at
// kEncodeLutSize points -> 8-bit) tables, built once.
const std::array<float, 256>& DecodeLut() {
  static const std::array<float, 256> lut = [] {
    std::array<float, 256> t;
    for (int v = 0; v < 256; ++v) {
      t[v] = static_cast<float>(SrgbToLinear(v / 255.0));
    }
    return t;
  }();
  return lut;
}

const std::vector<std::uint8_t>& EncodeLut() {
  static const std::vector<std::uint8_t> lut = [] {
    std::vector<std::uint8_t> t(kEncodeLutSize);
    for (int i = 0; i < kEncodeLutSize; ++i) {
      const double v = LinearToSrgb(i / double(kEncodeLutSize - 1));
      t[i] = static_cast<std::uint8_t>(
          std::clamp(std::lround(v * 255.0), 0L, 255L));
    }
    return t;
  }();
  return lut;
}

// Everything that is constant over one frame.
struct FrameConstants {
  bool is_8bit = false;
  const std::array<float, 256>& decode = DecodeLut();
  const std::vector<std::uint8_t>& encode = EncodeLut();

  bool tone = false;
  float source_cd = 1.0f, display_cd = 1.0f;
  float log10_source_cd = 0.0f;
  float tone_lo = 0.0f, tone_inv_step = 1.0f, tone_step = 1.0f;
  float tone_black = -10.0f;
  std::array<float, ToneCurve::kBins + 1> tone_y{};

  Method method = Method::kNone;
  // Shin: out = n c + n_t t + n_s s + n_v v (see PrepareShin).
  std::array<float, 9> n{};
  std::array<float, 3> n_t{}, n_s{}, n_v{}, w{}, d_c{};
  float d_t = 0.0f, k1 = 1.0f, k2 = 0.0f;
  std::vector<float> solve_log2_s;  // kSolveNodes entries
  float solve_lo_ls = 0.0f, solve_hi_ls = 0.0f;
  // Wanat saturation.
  float kappa = 0.1f;
  // Rods: out = rods * c.
  std::array<float, 9> rods{};
};

// Precomputes the Shin forward (at lux_src) + inverse (at lux_dst) as a
// linear part plus terms in t = Y'^gamma (forward), s = Y'' and v = s^gamma
// (inverse scotopic luminance).
void PrepareShin(double lux_src, double lux_dst, bool anchor_white,
                 FrameConstants& k) {
  const FittingOptions f = FittingAt(lux_src);
  const FittingOptions g = FittingAt(lux_dst);
  const Mat3 lms = Multiply(kXyzToLms, kRgbToXyz);
  const Vec3 white = Apply(lms, {1.0, 1.0, 1.0});
  const double lmw = white[0] + white[1];
  const Vec3 w = ScotopicWeights();
  constexpr Mat3 kOpp = {{{1.0, 1.0, 0.0}, {1.0, -2.0, 0.0}, {1.0, 1.0, -1.0}}};
  const Mat3 pqr_of_rgb = Multiply(kOpp, lms);
  // Forward: opp = F c + e0 * beta K'_w * t.
  Mat3 fwd;
  for (int j = 0; j < 3; ++j) {
    fwd[0][j] = f.alpha * kKw / lmw * pqr_of_rgb[0][j];
    fwd[1][j] = f.l * pqr_of_rgb[1][j] + f.a * w[j];
    fwd[2][j] = f.m * pqr_of_rgb[2][j] + f.b * w[j];
  }
  const double fwd_t = f.beta * kKwPrime;
  // Inverse: PQR = Dg opp - [p1 v, q1 s, r1 s]; rgb = G PQR.
  const Vec3 dg = {lmw / (g.alpha * kKw), 1.0 / g.l, 1.0 / g.m};
  const double p1 = dg[0] * g.beta * kKwPrime;
  const double q1 = g.a / g.l, r1 = g.b / g.m;
  const Mat3 gm = Inverse(pqr_of_rgb);
  Vec3 c{};  // Y' = c . PQR
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) c[j] += w[i] * gm[i][j];
  }
  Mat3 dgf;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) dgf[i][j] = dg[i] * fwd[i][j];
  }
  const Mat3 n = Multiply(gm, dgf);
  Vec3 gain = {1.0, 1.0, 1.0};
  if (anchor_white) {
    const Vec3 white_out =
        ShinInverse(ShinForward({1.0, 1.0, 1.0}, lux_src), lux_dst);
    for (int i = 0; i < 3; ++i) {
      if (white_out[i] > 1e-6) gain[i] = 1.0 / white_out[i];
    }
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      k.n[i * 3 + j] = static_cast<float>(gain[i] * n[i][j]);
    }
    k.n_t[i] = static_cast<float>(gain[i] * gm[i][0] * dg[0] * fwd_t);
    k.n_v[i] = static_cast<float>(gain[i] * -gm[i][0] * p1);
    k.n_s[i] = static_cast<float>(gain[i] * -(gm[i][1] * q1 + gm[i][2] * r1));
    k.w[i] = static_cast<float>(w[i]);
  }
  for (int j = 0; j < 3; ++j) {
    double d = 0.0;
    for (int i = 0; i < 3; ++i) d += c[i] * dgf[i][j];
    k.d_c[j] = static_cast<float>(d);
  }
  k.d_t = static_cast<float>(c[0] * dg[0] * fwd_t);
  const double k1 = 1.0 + c[1] * q1 + c[2] * r1;
  const double k2 = c[0] * p1;
  k.k1 = static_cast<float>(k1);
  k.k2 = static_cast<float>(k2);
  k.solve_log2_s.resize(kSolveNodes);
  for (int j = 0; j < kSolveNodes; ++j) {
    const double d =
        std::exp2(kSolveLo + (kSolveHi - kSolveLo) * j / (kSolveNodes - 1));
    double sol = d / k1;
    if (k2 > 0.0) {
      // Newton in v = s^gamma (convex, increasing) from an upper bound.
      double v = std::min(d / k2, std::pow(d / k1, kGamma));
      for (int it = 0; it < 100; ++it) {
        const double vp = std::pow(v, 1.0 / kGamma - 1.0);
        const double step =
            (k1 * vp * v + k2 * v - d) / (k1 / kGamma * vp + k2);
        v -= step;
        if (std::abs(step) <= 1e-14 * v) break;
      }
      sol = std::pow(v, 1.0 / kGamma);
    }
    k.solve_log2_s[j] = static_cast<float>(std::log2(sol));
  }
  k.solve_lo_ls = k.solve_log2_s.front();
  k.solve_hi_ls = k.solve_log2_s.back();
}

// Rod-contribution retargeting matrix (Eq. 6.12 without the luminance
// ratio, which the tone step already applied).
void PrepareRods(double lux_src, double lux_dst, bool anchor_white,
                 FrameConstants& k) {
  const Mat3 lms = Multiply(kXyzToLms, kRgbToXyz);
  const Vec3 w = ScotopicWeights();
  auto mc_me = [&](double lux) {
    const double rw = RodWeight(lux);
    const Vec3 kappa = {kRodKappa1 * rw, kRodKappa1 * rw, kRodKappa2 * rw};
    Mat3 m = lms;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m[i][j] += kappa[i] * w[j];
    }
    return m;
  };
  const Mat3 r = Multiply(Inverse(mc_me(lux_dst)), mc_me(lux_src));
  const Vec3 white_out = Apply(r, {1.0, 1.0, 1.0});
  for (int i = 0; i < 3; ++i) {
    const double gain =
        anchor_white && white_out[i] > 1e-6 ? 1.0 / white_out[i] : 1.0;
    for (int j = 0; j < 3; ++j) {
      k.rods[i * 3 + j] = static_cast<float>(gain * r[i][j]);
    }
  }
}

// --- per-row kernels on planar float arrays -------------------------------
// Written for GCC's vectoriser: constants copied to locals, __restrict
// pointers, and no conditional work in the loops (values are computed
// unconditionally and selected), which -ftrapping-math would otherwise keep
// as branches.

constexpr float kTiny = 1e-30f;

// On x86-64 the row kernels are also compiled for AVX2+FMA and picked at
// load time (GCC function multi-versioning); other targets use the baseline.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define HDRSTEREO_MESOPIC_KERNEL \
  __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define HDRSTEREO_MESOPIC_KERNEL
#endif

HDRSTEREO_MESOPIC_KERNEL void ToneRow(const FrameConstants& k, int n,
                                      float* __restrict r, float* __restrict g,
                                      float* __restrict b,
                                      float* __restrict ys_cd,
                                      float* __restrict yt_cd) {
  const float src_cd = k.source_cd, dst_cd = k.display_cd;
  if (!k.tone) {
    for (int i = 0; i < n; ++i) {
      const float lum = kLumR * r[i] + kLumG * g[i] + kLumB * b[i];
      ys_cd[i] = lum * src_cd;
      yt_cd[i] = lum * dst_cd;
    }
    return;
  }
  const float l10_2 = static_cast<float>(kLog10Of2);
  const float l2_10 = static_cast<float>(kLog2Of10);
  const float lo = k.tone_lo, inv_step = k.tone_inv_step, step = k.tone_step;
  const float black = k.tone_black, l10_src = k.log10_source_cd;
  const float top = static_cast<float>(ToneCurve::kBins);
  // Pass 1 (vectorised): bin coordinate u of log10 source luminance.
  for (int i = 0; i < n; ++i) {
    const float lum = kLumR * r[i] + kLumG * g[i] + kLumB * b[i];
    ys_cd[i] = lum * src_cd;
    const float x = FastLog2(lum) * l10_2 + l10_src;
    yt_cd[i] = std::min((x - lo) * inv_step, top);
  }
  // Pass 2 (table lookups; AVX2 gathers in that clone): log10 target
  // luminance. 0/1 masks instead of selects keep it vectorisable.
  const float* y = k.tone_y.data();
  const float y0 = y[0];
  for (int i = 0; i < n; ++i) {
    const float u = yt_cd[i];
    const float uc = std::max(u, 0.0f);
    const int j = std::min(static_cast<int>(uc), ToneCurve::kBins - 1);
    const float f = uc - static_cast<float>(j);
    const float inside = y[j] + (y[j + 1] - y[j]) * f;
    const float below = std::max(y0 + u * step, black);
    const float neg = u < 0.0f ? 1.0f : 0.0f;
    yt_cd[i] = inside + neg * (below - inside);
  }
  // Pass 3 (vectorised): scale colours to the target luminance.
  const float inv_dst = 1.0f / dst_cd;
  for (int i = 0; i < n; ++i) {
    const float lum_cd = ys_cd[i];
    const float yt = FastExp2(yt_cd[i] * l2_10);
    // Multiplying by a 0/1 mask (not selecting) keeps the AVX2 clone
    // vectorised.
    const float lit = lum_cd > 0.0f ? 1.0f : 0.0f;
    const float scale = lit * yt * inv_dst * src_cd / std::max(lum_cd, kTiny);
    yt_cd[i] = lit * yt;
    r[i] *= scale;
    g[i] *= scale;
    b[i] *= scale;
  }
}

// `x` is scratch space of n floats.
HDRSTEREO_MESOPIC_KERNEL void ShinRow(const FrameConstants& k, int n,
                                      float* __restrict r, float* __restrict g,
                                      float* __restrict b, float* __restrict x,
                                      float* __restrict tt) {
  constexpr float kG = static_cast<float>(kGamma);
  constexpr float kInvG = static_cast<float>(1.0 / kGamma);
  const float k1 = k.k1, k2 = k.k2, k2g = k.k2 * kG;
  const float w0 = k.w[0], w1 = k.w[1], w2 = k.w[2];
  const float dc0 = k.d_c[0], dc1 = k.d_c[1], dc2 = k.d_c[2], dt = k.d_t;
  const std::array<float, 9> m = k.n;
  const std::array<float, 3> nt = k.n_t, ns = k.n_s, nv = k.n_v;
  const float lo = static_cast<float>(kSolveLo);
  const float inv_dx =
      static_cast<float>((kSolveNodes - 1) / (kSolveHi - kSolveLo));
  const float dx =
      static_cast<float>((kSolveHi - kSolveLo) / (kSolveNodes - 1));
  const float umax = static_cast<float>(kSolveNodes - 1);
  // Pass 1 (vectorised): forward model, t = Y'^gamma, and the bin
  // coordinate of log2 d.
  for (int i = 0; i < n; ++i) {
    const float y = std::max(w0 * r[i] + w1 * g[i] + w2 * b[i], 0.0f);
    const float t = FastPow(y, kG);
    tt[i] = t;
    const float d = dc0 * r[i] + dc1 * g[i] + dc2 * b[i] + dt * t;
    x[i] = (FastLog2(d) - lo) * inv_dx;  // d <= 0 gives a far-left value
  }
  // Pass 2 (table lookups; AVX2 gathers in that clone): log2 s.
  const float* __restrict tab = k.solve_log2_s.data();
  const float lo_ls = k.solve_lo_ls, hi_ls = k.solve_hi_ls;
  // Asymptotes: s ~ (d/k2)^(1/gamma) for small d, s ~ d/k1 for large d.
  const float slope_lo = dx * (k2 > 0.0f ? kInvG : 1.0f);
  for (int i = 0; i < n; ++i) {
    const float u = x[i];
    const float uc = std::min(std::max(u, 0.0f), umax);
    const int j = std::min(static_cast<int>(uc), kSolveNodes - 2);
    const float f = uc - static_cast<float>(j);
    const float inside = tab[j] + (tab[j + 1] - tab[j]) * f;
    const float below = lo_ls + u * slope_lo;
    const float above = hi_ls + (u - umax) * dx;
    const float neg = u < 0.0f ? 1.0f : 0.0f;
    const float over = u > umax ? 1.0f : 0.0f;
    x[i] = inside + neg * (below - inside) + over * (above - inside);
  }
  // Pass 3 (vectorised): one Newton step on k1 s + k2 s^gamma = d, then
  // the linear output map.
  for (int i = 0; i < n; ++i) {
    const float cr = r[i], cg = g[i], cb = b[i];
    const float t = tt[i];
    const float d = std::max(dc0 * cr + dc1 * cg + dc2 * cb + dt * t, 0.0f);
    const float ls = x[i];
    float s = FastExp2(ls);
    float v = FastExp2(kG * ls);
    const float fs = k1 * s + k2 * v - d;
    const float dfs = k1 + k2g * v / std::max(s, kTiny);
    const float s_new = std::max(s - fs / dfs, 0.0f);
    v = std::max(v + kG * v / std::max(s, kTiny) * (s_new - s), 0.0f);
    s = s_new;
    const bool dark = d <= 0.0f;
    s = dark ? 0.0f : s;
    v = dark ? 0.0f : v;
    r[i] =
        m[0] * cr + m[1] * cg + m[2] * cb + nt[0] * t + ns[0] * s + nv[0] * v;
    g[i] =
        m[3] * cr + m[4] * cg + m[5] * cb + nt[1] * t + ns[1] * s + nv[1] * v;
    b[i] =
        m[6] * cr + m[7] * cg + m[8] * cb + nt[2] * t + ns[2] * s + nv[2] * v;
  }
}

HDRSTEREO_MESOPIC_KERNEL void WanatSaturationRow(
    const FrameConstants& k, int n, float* __restrict r, float* __restrict g,
    float* __restrict b, const float* __restrict ys_cd,
    const float* __restrict yt_cd) {
  const float kappa = k.kappa;
  for (int i = 0; i < n; ++i) {
    const float ys = ys_cd[i], yt = yt_cd[i];
    const float s_src = ys / (ys + kappa);
    const float s_dst = yt / (yt + kappa);
    const float p = s_dst > 0.0f ? s_src / std::max(s_dst, kTiny) : 1.0f;
    const float lum = kLumR * r[i] + kLumG * g[i] + kLumB * b[i];
    const float inv = lum > 0.0f ? 1.0f / std::max(lum, kTiny) : 0.0f;
    r[i] = lum * FastPow(r[i] * inv, p);
    g[i] = lum * FastPow(g[i] * inv, p);
    b[i] = lum * FastPow(b[i] * inv, p);
  }
}

HDRSTEREO_MESOPIC_KERNEL void RodsRow(const FrameConstants& k, int n,
                                      float* __restrict r, float* __restrict g,
                                      float* __restrict b) {
  const std::array<float, 9> m = k.rods;
  for (int i = 0; i < n; ++i) {
    const float cr = r[i], cg = g[i], cb = b[i];
    r[i] = m[0] * cr + m[1] * cg + m[2] * cb;
    g[i] = m[3] * cr + m[4] * cg + m[5] * cb;
    b[i] = m[6] * cr + m[7] * cg + m[8] * cb;
  }
}

inline float Clip01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }

// Pulls out-of-gamut colours towards the grey of the same (clipped)
// luminance just enough to fit in [0,1]^3.
HDRSTEREO_MESOPIC_KERNEL void GamutRow(int n, float* __restrict r,
                                       float* __restrict g,
                                       float* __restrict b) {
  for (int i = 0; i < n; ++i) {
    const float cr = r[i], cg = g[i], cb = b[i];
    const float yc = Clip01(kLumR * cr + kLumG * cg + kLumB * cb);
    // Largest t in [0,1] keeping yc + t (c - yc) in [0,1] for every channel:
    // only the largest and the smallest channel can bind.
    const float mx = std::max(std::max(cr, cg), cb);
    const float mn = std::min(std::min(cr, cg), cb);
    const float t_hi =
        mx > 1.0f ? (1.0f - yc) / std::max(mx - yc, kTiny) : 1.0f;
    const float t_lo = mn < 0.0f ? yc / std::max(yc - mn, kTiny) : 1.0f;
    const float t = std::min(t_hi, t_lo);
    r[i] = Clip01(yc + t * (cr - yc));
    g[i] = Clip01(yc + t * (cg - yc));
    b[i] = Clip01(yc + t * (cb - yc));
  }
}

// [0, kMaxInput]; NaN gives 0.
inline float ClampInput(float v) {
  return v > 0.0f ? std::min(v, kMaxInput) : 0.0f;
}

// True if none of the n values is NaN or infinite (vectorisable OR).
HDRSTEREO_MESOPIC_KERNEL bool AllFinite(const float* __restrict p, int n) {
  int bad = 0;
  for (int i = 0; i < n; ++i) {
    bad |= !(std::abs(p[i]) <= std::numeric_limits<float>::max());
  }
  return bad == 0;
}

// Interleaved BGR float <-> planar R, G, B.
HDRSTEREO_MESOPIC_KERNEL void LoadFloatRow(const float* __restrict p, int n,
                                           float* __restrict r,
                                           float* __restrict g,
                                           float* __restrict b) {
  for (int x = 0; x < n; ++x) {
    b[x] = ClampInput(p[3 * x]);
    g[x] = ClampInput(p[3 * x + 1]);
    r[x] = ClampInput(p[3 * x + 2]);
  }
}

HDRSTEREO_MESOPIC_KERNEL void StoreFloatRow(const float* __restrict r,
                                            const float* __restrict g,
                                            const float* __restrict b, int n,
                                            float* __restrict q) {
  for (int x = 0; x < n; ++x) {
    q[3 * x] = b[x];
    q[3 * x + 1] = g[x];
    q[3 * x + 2] = r[x];
  }
}

absl::Status ValidateOptions(const RetargetOptions& o) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!(o.display_cd <= kMaxLuminance) || !(o.source_cd <= kMaxLuminance)) {
    return absl::InvalidArgumentError(
        absl::StrCat("luminances above ", kMaxLuminance,
                     " cd/m^2 are not supported (display ", o.display_cd,
                     ", source ", o.source_cd, ")"));
  }
  if (!positive(o.display_cd)) {
    return absl::InvalidArgumentError(
        absl::StrCat("display luminance must be a positive number of cd/m^2, "
                     "got ",
                     o.display_cd));
  }
  if (!positive(o.source_cd)) {
    return absl::InvalidArgumentError(
        absl::StrCat("source luminance must be a positive number of cd/m^2, "
                     "got ",
                     o.source_cd));
  }
  if (!std::isfinite(o.display_contrast) || o.display_contrast <= 1.0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "display contrast (peak/black) must be > 1, got ", o.display_contrast));
  }
  if (!positive(o.saturation_kappa)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "saturation kappa must be positive, got ", o.saturation_kappa));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<cv::Mat> Retarget(const cv::Mat& image,
                                 const RetargetOptions& options) {
  cv::Mat out;
  RETURN_IF_ERROR(RetargetInto(image, options, &out));
  return out;
}

absl::Status RetargetInto(const cv::Mat& image, const RetargetOptions& options,
                          cv::Mat* out_ptr) {
  if (out_ptr == nullptr) {
    return absl::InvalidArgumentError("mesopic retarget: null output");
  }
  if (image.empty()) {
    return absl::InvalidArgumentError("mesopic retarget: input image is empty");
  }
  if (image.channels() != 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("mesopic retarget: need a 3-channel BGR image, got ",
                     image.channels(), " channel(s)"));
  }
  if (image.depth() != CV_8U && image.depth() != CV_32F) {
    return absl::InvalidArgumentError(
        "mesopic retarget: need CV_8UC3 (sRGB) or CV_32FC3 (linear) input");
  }
  RETURN_IF_ERROR(ValidateOptions(options));
  try {
    FrameConstants k;
    k.is_8bit = image.depth() == CV_8U;
    k.source_cd = static_cast<float>(options.source_cd);
    k.display_cd = static_cast<float>(options.display_cd);
    k.log10_source_cd = static_cast<float>(std::log10(options.source_cd));
    k.method = options.method;
    k.kappa = static_cast<float>(options.saturation_kappa);
    k.tone = options.tone_curve;

    const int rows = image.rows, cols = image.cols;
    auto load_pixel = [&](int y, int x, float& r, float& g, float& b) {
      if (k.is_8bit) {
        const auto& p = image.at<cv::Vec3b>(y, x);
        b = k.decode[p[0]];
        g = k.decode[p[1]];
        r = k.decode[p[2]];
      } else {
        const auto& p = image.at<cv::Vec3f>(y, x);
        b = ClampInput(p[0]);
        g = ClampInput(p[1]);
        r = ClampInput(p[2]);
      }
    };

    if (k.tone) {
      // Histogram sample: every 4th pixel of every 4th row.
      std::vector<float> samples;
      samples.reserve(static_cast<size_t>((rows / 4 + 1) * (cols / 4 + 1)));
      for (int y = 0; y < rows; y += 4) {
        for (int x = 0; x < cols; x += 4) {
          float r, g, b;
          load_pixel(y, x, r, g, b);
          samples.push_back((kLumR * r + kLumG * g + kLumB * b) * k.source_cd);
        }
      }
      // Peak: the source white, or the 99.9th percentile of HDR input above
      // it (brighter highlights clip to the display white).
      std::vector<float> sorted = samples;
      const auto nth = sorted.begin() + (sorted.size() * 999) / 1000;
      std::nth_element(sorted.begin(), nth, sorted.end());
      const double peak =
          std::max(options.source_cd, static_cast<double>(*nth));
      const ToneCurve curve =
          ToneCurve::Build(samples, peak, options.display_cd,
                           options.display_cd / options.display_contrast);
      k.tone_lo = static_cast<float>(curve.lo_log10());
      k.tone_step = static_cast<float>(curve.step_log10());
      k.tone_inv_step = static_cast<float>(1.0 / curve.step_log10());
      k.tone_black = static_cast<float>(curve.black_log10());
      for (int j = 0; j <= ToneCurve::kBins; ++j) {
        k.tone_y[j] = static_cast<float>(curve.y_log10()[j]);
      }
    }
    const double lux_src = LuxFromWhiteLuminance(options.source_cd);
    const double lux_dst = LuxFromWhiteLuminance(options.display_cd);
    if (k.method == Method::kShin)
      PrepareShin(lux_src, lux_dst, options.anchor_white, k);
    if (k.method == Method::kRods)
      PrepareRods(lux_src, lux_dst, options.anchor_white, k);

    if (out_ptr->data != nullptr && out_ptr->datastart == image.datastart) {
      return absl::InvalidArgumentError(
          "mesopic retarget: output must not share data with the input");
    }
    out_ptr->create(rows, cols, image.type());
    cv::Mat& out = *out_ptr;
    // NaN/Inf input is detected while reading rows (cheaper than a separate
    // cv::checkRange pass); the (meaningless) output is then discarded.
    std::atomic<bool> non_finite{false};
    cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
      std::vector<float> buf(static_cast<size_t>(cols) * 7);
      float* r = buf.data();
      float* g = r + cols;
      float* b = g + cols;
      float* ys = b + cols;
      float* yt = ys + cols;
      float* scratch1 = yt + cols;
      float* scratch2 = scratch1 + cols;
      for (int y = range.start; y < range.end; ++y) {
        if (k.is_8bit) {
          const std::uint8_t* p = image.ptr<std::uint8_t>(y);
          for (int x = 0; x < cols; ++x) {
            b[x] = k.decode[p[3 * x]];
            g[x] = k.decode[p[3 * x + 1]];
            r[x] = k.decode[p[3 * x + 2]];
          }
        } else {
          const float* p = image.ptr<float>(y);
          if (!AllFinite(p, 3 * cols)) {
            non_finite.store(true, std::memory_order_relaxed);
          }
          LoadFloatRow(p, cols, r, g, b);
        }
        ToneRow(k, cols, r, g, b, ys, yt);
        switch (k.method) {
          case Method::kShin:
            ShinRow(k, cols, r, g, b, scratch1, scratch2);
            break;
          case Method::kWanatSaturation:
            WanatSaturationRow(k, cols, r, g, b, ys, yt);
            break;
          case Method::kRods:
            RodsRow(k, cols, r, g, b);
            break;
          case Method::kNone:
            break;
        }
        GamutRow(cols, r, g, b);
        if (k.is_8bit) {
          std::uint8_t* q = out.ptr<std::uint8_t>(y);
          const float scale = kEncodeLutSize - 1;
          for (int x = 0; x < cols; ++x) {
            q[3 * x] = k.encode[static_cast<int>(b[x] * scale + 0.5f)];
            q[3 * x + 1] = k.encode[static_cast<int>(g[x] * scale + 0.5f)];
            q[3 * x + 2] = k.encode[static_cast<int>(r[x] * scale + 0.5f)];
          }
        } else {
          StoreFloatRow(r, g, b, cols, out.ptr<float>(y));
        }
      }
    });
    if (non_finite.load()) {
      return absl::InvalidArgumentError(
          "mesopic retarget: input contains NaN or infinite values");
    }
    return absl::OkStatus();
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("mesopic retarget: OpenCV error: ", e.what()));
  }
}

}  // namespace hdrstereo::mesopic
