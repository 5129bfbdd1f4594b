// SPDX-License-Identifier: GPL-3.0-or-later
//
// The seven tone-mapping operators compared in thesis Sec. 5.1, with one
// interface: linear HDR radiance (CV_32FC3, OpenCV's BGR order, any positive
// scale) in, gamma-encoded 8-bit display image (CV_8UC3) out.
//
//   reinhard          Reinhard et al. 2002, global photographic operator:
//                     L = key / Lavg * Lw, Ld = L (1 + L / Lwhite^2) / (1 + L),
//                     Lavg the log-average luminance, Lwhite the white point
//                     (default: the largest scaled luminance).
//   drago             Drago et al. 2003, adaptive logarithmic mapping:
//                     Lw = L / Lavg, Ld = (ld_max / 100) / log10(Lwmax + 1)
//                     * ln(Lw + 1) / ln(2 + 8 (Lw / Lwmax)^(ln b / ln 0.5)),
//                     bias b = 0.85 (Lwmax maps to 1).
//   durand            Durand & Dorsey 2002: base/detail on log10 luminance,
//                     base = bilateral filter (our piecewise-linear fast
//                     bilateral, sigma_s = 2 % of the image size,
//                     sigma_r = 0.4), base contrast reduced to
//                     `base_contrast`, detail kept.
//   fattal            Fattal et al. 2002: log-luminance gradients attenuated
//                     by (|grad| / alpha)^(beta - 1) accumulated over a
//                     Gaussian pyramid (alpha = 0.1 x the level's mean
//                     gradient, beta = 0.85), image recovered by a DCT
//                     Poisson solve (Neumann boundary); the free constant is
//                     fixed on the mid-tones (see fattal.h).
//   guided            "He": the Durand scheme with the guided filter
//                     (r = 9, eps = 1e-4) as the edge-aware filter.
//   domain-transform  "Gastal": the Durand scheme with the domain-transform
//                     recursive filter (sigma_s = 60, sigma_r = 0.33).
//   wls               "Farbman": the Durand scheme with the WLS filter
//                     (alpha = 1.2, lambda = 1).
//
// Base/detail (Durand's scheme): l = log10 L, base B = filter(l), detail
// D = l - B; log10 Ld = log10(base_contrast) / (Bmax - Bmin) * (B - Bmax) + D.
// All four base/detail operators filter log10 luminance itself (Durand's
// domain), so the thesis' parameters are in decades: Gastal's sigma_r = 0.33
// is close to Durand's 0.4, He's eps = 1e-4 is a 0.01-decade (2 %) noise
// level, Farbman's weights see log10 gradients. No per-image normalisation
// is involved, which also keeps stereo pairs consistent.
//
// Display step, shared by all operators:
//   luminance L = 0.2126 R + 0.7152 G + 0.0722 B, floored at 1e-6 times the
//   pair's maximum (so black pixels do not dominate log statistics);
//   local operators (durand, fattal, guided, domain-transform, wls) stretch
//   the display luminance linearly so that the pair's `clip_low` /
//   `clip_high` percentiles map to 0 / 1; the global ones (reinhard, drago)
//   are used as is (both already map the white point to 1);
//   colour: C_out = (C_in / L)^saturation * Ld (Schlick / Fattal style
//   saturation exponent; 1 keeps the ratios, < 1 desaturates);
//   encoding: V = round(255 * clamp(C_out, 0, 1)^(1 / gamma)).
//
// Pairs: ToneMapPair computes every image statistic (log-average, min/max,
// the base layer's range, Fattal's per-level mean gradient, percentiles)
// over BOTH views together and applies the same curve to both, so the same
// radiance maps to the same value in both views (exactly for the global
// operators; up to the spatial support of the filters for the local ones).
#ifndef HDRSTEREO_PROCESSING_TONEMAP_TONEMAP_H_
#define HDRSTEREO_PROCESSING_TONEMAP_TONEMAP_H_

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "processing/filters/domain_transform.h"
#include "processing/filters/guided_filter.h"
#include "processing/filters/wls_filter.h"

namespace hdrstereo::tonemap {

enum class Operator {
  kReinhard,
  kDurand,
  kFattal,
  kDrago,
  kGuided,           // He
  kDomainTransform,  // Gastal
  kWls,              // Farbman
};

struct ReinhardOptions {
  double key = 0.18;
  // White point in scaled luminance units; <= 0 means the largest scaled
  // luminance of the image (pair), which then maps to 1.
  double white = 0.0;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
void to_json(nlohmann::json& j, const ReinhardOptions& o);

struct DragoOptions {
  double bias = 0.85;
  double ld_max = 100.0;  // display maximum, cd/m^2 (Ldmax in the paper)

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
void to_json(nlohmann::json& j, const DragoOptions& o);

struct DurandOptions {
  double sigma_s_fraction = 0.02;  // spatial sigma / max(width, height)
  double sigma_r = 0.4;            // range sigma, log10 units

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
void to_json(nlohmann::json& j, const DurandOptions& o);

struct FattalOptions {
  double alpha = 0.1;  // times the pair's mean gradient magnitude per level
  double beta = 0.85;  // < 1 compresses large gradients; 1 = no attenuation
  int min_level_size = 32;  // coarsest pyramid level's smaller side
  // Views wider than this are compressed resized to this width (area
  // average); the change that makes to their log luminance is brought back
  // to their size (bilinear) and added there, so the finest detail is not
  // attenuated. 0 = at the views' own size, as Fattal et al. do. In
  // pixels: integrating a field that the attenuation made non-integrable
  // spreads the error over more pixels at larger sizes, and the views drift
  // apart at the right edge (lab-lamp at 1200 px: RMSE 31.06 / bad-1px
  // 86.4 % at full size, 10.76 / 59.8 % at this width; docs/results.md).
  // 320 px is the thesis table's size.
  int solve_width = 320;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
void to_json(nlohmann::json& j, const FattalOptions& o);

struct Params {
  double saturation = 0.6;   // colour exponent, see above
  double gamma = 2.2;        // display encoding exponent
  double clip_low = 0.001;   // fraction of pixels clipped to black (local ops)
  double clip_high = 0.001;  // fraction clipped to white (local ops)
  double base_contrast = 5.0;  // target contrast of the base layer (Durand)
  ReinhardOptions reinhard;
  DragoOptions drago;
  DurandOptions durand;
  FattalOptions fattal;
  filters::GuidedFilterOptions guided;               // r = 9, eps = 1e-4
  filters::DomainTransformOptions domain_transform;  // 60, 0.33, 3 iters
  filters::WlsOptions wls;                           // 1.2, 1

  // INVALID_ARGUMENT naming the first field that breaks a rule, nested
  // fields with their path ("guided.radius is 0; ...").
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const Params& o);

// "reinhard", "durand", "fattal", "drago", "guided", "domain-transform",
// "wls" (exact, lower case).
absl::StatusOr<Operator> OperatorFromName(absl::string_view name);
std::string OperatorName(Operator op);
// All seven, in the thesis' order (Reinhard, Durand, Fattal, Drago, He,
// Gastal, Farbman).
std::vector<Operator> AllOperators();

// radiance: CV_32FC3, non-empty, finite, non-negative, not all zero.
absl::StatusOr<cv::Mat> ToneMap(const cv::Mat& radiance, Operator op,
                                const Params& params = {});

// Both views tone-mapped with statistics shared over the pair (see above).
// The views must both be valid radiance images; sizes may differ.
absl::StatusOr<std::pair<cv::Mat, cv::Mat>> ToneMapPair(
    const cv::Mat& left, const cv::Mat& right, Operator op,
    const Params& params = {});

// Any number of views sharing one normalisation (ToneMap = one view,
// ToneMapPair = two).
absl::StatusOr<std::vector<cv::Mat>> ToneMapViews(
    const std::vector<cv::Mat>& radiance, Operator op,
    const Params& params = {});

}  // namespace hdrstereo::tonemap

#endif  // HDRSTEREO_PROCESSING_TONEMAP_TONEMAP_H_
