// SPDX-License-Identifier: GPL-3.0-or-later
//
// Mesopic retargeting (thesis chapter 6): render an image for a dim display
// in a dark room so that it keeps its perceived colour and contrast.
//
//   RetargetOptions opt;            // display 2 cd/m^2, source 200 cd/m^2
//   opt.method = Method::kShin;     // thesis method 5 with tone_curve=true
//   absl::StatusOr<cv::Mat> out = Retarget(image, opt);
//
// Pipeline per frame: (1) decode to linear RGB relative to the source white;
// (2) optional global tone curve (tone_curve.h) from source luminance to the
// display's luminance range, applied to luminance with chromaticity kept;
// (3) colour retargeting with `method`; (4) gamut clipping; (5) encode.
//
// Images are OpenCV 3-channel BGR. CV_8UC3 is taken as sRGB-encoded and
// returned sRGB-encoded; CV_32FC3 is taken as linear with 1.0 = source white
// (values above 1 are allowed up to 1e9; negatives are treated as 0; the
// tone curve maps max(source white, 99.9th percentile) to the display
// white) and returned linear relative to the display white, in [0, 1].
//
// Colour retargeting works on the tone-mapped colours: the Shin model is
// evaluated at the source level E = pi * source_cd and inverted at the
// display level E' = pi * display_cd (see docs/mesopic.md).
//
// Gamut: out-of-range results are pulled towards the grey of the same
// luminance (hue and luminance kept, chroma reduced) just enough to fit;
// luminance above white is clipped to white. Never NaN, never outside [0,1].
#ifndef HDRSTEREO_PROCESSING_MESOPIC_RETARGET_H_
#define HDRSTEREO_PROCESSING_MESOPIC_RETARGET_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "opencv2/core.hpp"

namespace hdrstereo::mesopic {

enum class Method {
  kNone,             // tone curve only (or plain dimming)
  kShin,             // Shin forward at the source level, inverse at the
                     // display level (thesis 6.3, method 5 with tone curve)
  kWanatSaturation,  // Wanat & Mantiuk saturation correction (Eq. 6.9)
  kRods,             // rod-contribution model (Eqs. 6.10-6.12)
};

// "none", "shin", "wanat-saturation" (or "wanat_saturation"), "rods".
absl::StatusOr<Method> MethodFromName(absl::string_view name);
std::string MethodName(Method method);

struct RetargetOptions {
  double display_cd = 2.0;   // target display white luminance, cd/m^2
  double source_cd = 200.0;  // luminance the source white was meant for
  Method method = Method::kShin;
  bool tone_curve = true;            // global tone retargeting before colour
  double display_contrast = 1000.0;  // display peak / black (> 1)
  double saturation_kappa = 0.1;     // kappa of Eq. 6.9, cd/m^2 (> 0)
  // Shin and rods methods: scale the output channels so that the source
  // white stays the display white. Eq. 6.2's opponent channels are not zero
  // for white (L-2M and L+M-S of D65 are -0.04 and -0.09), so the
  // level-dependent gains l(E), m(E) tint neutrals (about 6% less red for
  // mid-grey at 2 cd/m^2); anchoring reduces that to about 1%. Eq. 6.12
  // likewise tints white (magenta with our kappa values); anchored it is
  // exact for greys. False gives the equations unmodified.
  bool anchor_white = true;
};

// Retargets `image` (CV_8UC3 sRGB or CV_32FC3 linear, BGR) for the display
// described by `options`. Returns an image of the same size and type, or
// INVALID_ARGUMENT for empty/unsupported images, NaN/Inf pixels or bad
// options, INTERNAL if OpenCV throws.
absl::StatusOr<cv::Mat> Retarget(const cv::Mat& image,
                                 const RetargetOptions& options);

// Same, writing into `*out` (reallocated only if its size or type differ),
// for video where the output buffer is reused frame after frame. `out` must
// not share data with `image`. On error the contents of `*out` are
// unspecified.
absl::Status RetargetInto(const cv::Mat& image, const RetargetOptions& options,
                          cv::Mat* out);

}  // namespace hdrstereo::mesopic

#endif  // HDRSTEREO_PROCESSING_MESOPIC_RETARGET_H_
