// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Shin et al. (2004) mesopic colour appearance model (thesis 6.3.1,
// Eqs. 6.1-6.3) and its inverse for compensation (thesis 6.3.2, Eqs.
// 6.4-6.5).
//
// Units. Colours are linear sRGB/Rec.709 triples in RGB order, relative to
// the white of the viewing condition (white = (1,1,1), Y_w = 1, Y'_w = 1).
// The viewing condition itself enters only through the fitting functions,
// which are indexed by illuminance E in lux. A display or scene whose white
// has luminance L cd/m^2 corresponds to E = pi * L lx (a white Lambertian
// surface; see LuxFromWhiteLuminance).
//
// Fitting functions. Shin et al.'s Table 1 was not available to us (the
// thesis only cites it). kShinFittingTable holds values we derived; see
// docs/mesopic.md and the comment on the table for the derivation.
#ifndef HDRSTEREO_PROCESSING_MESOPIC_SHIN_MODEL_H_
#define HDRSTEREO_PROCESSING_MESOPIC_SHIN_MODEL_H_

#include <array>

namespace hdrstereo::mesopic {

using Mat3 = std::array<std::array<double, 3>, 3>;
using Vec3 = std::array<double, 3>;

// Thesis Table 6.1.
inline constexpr double kKw = 1.0;        // photopic max response
inline constexpr double kKwPrime = 78.4;  // scotopic max response K'_w
inline constexpr double kGamma = 0.77;    // scotopic exponent

// Thesis Table 6.2, row-major, exactly as printed.
inline constexpr Mat3 kRgbToXyz = {{{0.4124, 0.3576, 0.1805},
                                    {0.2126, 0.7152, 0.0722},
                                    {0.0193, 0.1192, 0.9505}}};
inline constexpr Mat3 kXyzToLms = {
    {{0.155, 0.543, -0.03286}, {-0.155, 0.457, 0.033}, {0.0, 0.0, 1.0}}};
inline constexpr Mat3 kOppToXyz = {
    {{1.008, 2.149, -0.212}, {1.0, 0.0, 0.0}, {1.0, 0.0, -1.0}}};

// Scotopic luminance Y' of linear RGB, normalised so that white gives 1.
// The thesis does not say how Y' is computed. We evaluate Larson et al.'s
// (1997) scotopic approximation Y' = Y (1.33 (1 + (Y + Z) / X) - 1.68) at
// each Table 6.2 primary and use the results (normalised to sum to one) as a
// linear rod sensitivity of the display primaries: R 0.032881, G 0.765451,
// B 0.201668. This keeps Y' linear in RGB (and never negative for
// non-negative RGB), which the inverse model relies on.
Vec3 ScotopicWeights();
double ScotopicLuminance(const Vec3& rgb);

// Fitting functions of Eq. 6.2 at one illuminance.
struct FittingOptions {
  double alpha = 1.0;  // weight of the cone (photopic) achromatic signal
  double beta = 0.0;   // weight of the rod achromatic signal
  double l = 1.0;      // red/green cone gain
  double a = 0.0;      // rod input to red/green
  double m = 1.0;      // blue/yellow cone gain
  double b = 0.0;      // rod input to blue/yellow
};

struct FittingNode {
  double lux;
  FittingOptions params;
};

// The tabulated fitting functions (derived; see docs/mesopic.md), ascending
// in illuminance. Values between nodes are interpolated linearly in
// log10(E); outside the table the end values hold.
inline constexpr int kFittingNodes = 6;
extern const std::array<FittingNode, kFittingNodes> kShinFittingTable;

// Fitting functions at illuminance `lux` (> 0).
FittingOptions FittingAt(double lux);

// E = pi * L: illuminance on a white Lambertian surface of luminance L.
double LuxFromWhiteLuminance(double cd_per_m2);

// Share of rod signal in the achromatic channel for white, w(E) in [0, 1]:
// 0 at and above 5 cd/m^2, 1 at and below 0.005 cd/m^2 (the CIE 191:2010
// mesopic range), linear in log luminance in between.
double RodWeight(double lux);

// Opponent responses of Eq. 6.2.
struct Opponent {
  double achromatic = 0.0;   // A(E)
  double red_green = 0.0;    // r/g(E)
  double blue_yellow = 0.0;  // b/y(E)
};

// Forward model: linear RGB (relative to white) viewed at illuminance `lux`
// -> opponent responses.
Opponent ShinForward(const Vec3& rgb, double lux);

// The colour a photopic observer would match to `opp` (Eq. 6.3):
// XYZ = M_opp2xyz [A r/g b/y]^t, relative to white (Y_w = 1). This is the
// "simulation" output of the model.
Vec3 PerceivedXyz(const Opponent& opp);

// Inverse model (Eqs. 6.4-6.5): the linear RGB that, viewed at `lux`,
// produces the opponent responses `opp`. The scotopic luminance of the
// answer appears on both sides of Eq. 6.4; it is solved for exactly (a
// scalar monotone equation, Newton's method). The result is not clipped.
Vec3 ShinInverse(const Opponent& opp, double lux);

// Matrix helpers (exposed for tests).
Mat3 Multiply(const Mat3& a, const Mat3& b);
Vec3 Apply(const Mat3& m, const Vec3& v);
Mat3 Inverse(const Mat3& m);

}  // namespace hdrstereo::mesopic

#endif  // HDRSTEREO_PROCESSING_MESOPIC_SHIN_MODEL_H_
