// SPDX-License-Identifier: GPL-3.0-or-later
//
// Global tone retargeting after Wanat & Mantiuk (2014): a monotone tone curve
// from source luminance (cd/m^2) to target-display luminance that keeps the
// perceived contrast of the image on a dimmer display, within the display's
// dynamic range.
//
// Simplifications (see docs/mesopic.md): the curve is piecewise linear in
// log luminance over 64 bins. Perceived contrast is matched per bin with
// Kulikowski's rule (supra-threshold contrast minus threshold is kept, as
// Wanat & Mantiuk do), using a simple threshold-vs-intensity model
// C_t(L) = 0.01 (1 + 1/sqrt(L)) instead of their full CSF; the local slope
// of bin i becomes k_i = 1 + (G(L_t) - G(L_s)) / kReferenceContrast with
// G(L) = log10(1 + C_t(L)). Empty histogram bins get slope 1; when the
// result does not fit the display's range (peak / black), empty bins are
// compressed first, then all bins uniformly. The peak maps to the display
// peak. No spatial (local) contrast processing.
#ifndef HDRSTEREO_PROCESSING_MESOPIC_TONE_CURVE_H_
#define HDRSTEREO_PROCESSING_MESOPIC_TONE_CURVE_H_

#include <span>
#include <vector>

namespace hdrstereo::mesopic {

// Log10 contrast that is matched between source and target (0.1 log units,
// a mid-level image contrast).
inline constexpr double kReferenceContrast = 0.1;

// Detection threshold (Weber contrast) at luminance `cd` (> 0).
double ContrastThreshold(double cd);

class ToneCurve {
 public:
  static constexpr int kBins = 64;

  // `source_cd` samples of source luminance (non-positive and non-finite
  // ones are ignored); `source_peak_cd` the source luminance mapped to
  // `display_cd`; `display_black_cd` the darkest luminance the display
  // shows. The three luminances must be positive and finite.
  static ToneCurve Build(std::span<const float> source_cd,
                         double source_peak_cd, double display_cd,
                         double display_black_cd);

  // Target luminance (cd/m^2) for source luminance `cd`; 0 maps to 0.
  double Map(double cd) const;

  // The curve as nodes in log10 space: node j is at
  // x = lo_log10() + j * step_log10(), value y_log10()[j].
  double lo_log10() const { return lo_; }
  double step_log10() const { return step_; }
  const std::vector<double>& y_log10() const { return y_; }
  double black_log10() const { return black_; }

 private:
  double lo_ = 0.0;
  double step_ = 1.0;
  double black_ = -10.0;
  std::vector<double> y_;
};

}  // namespace hdrstereo::mesopic

#endif  // HDRSTEREO_PROCESSING_MESOPIC_TONE_CURVE_H_
