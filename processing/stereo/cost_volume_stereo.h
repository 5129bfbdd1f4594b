// SPDX-License-Identifier: GPL-3.0-or-later
//
// Fast cost-volume filtering stereo (Hosni, Rhemann, Bleyer, Rother &
// Gelautz, TPAMI 2013) with the HDR cost of the thesis (Akhavan, ch. 4.1).
//
// Pipeline (ComputeDisparity):
//   1. Matching images: LDR input scaled to [0,1] (8-bit / 255, 16-bit /
//      65535, float as is); HDR input (radiance) divided by the pair's
//      maximum so that both views lie in [0,1] with one common scale.
//   2. Cost per disparity slice d (thesis Eq. 4.1):
//        C = alpha min(|I - I'|, tau1) + (1 - alpha) min(|dx G - dx G'|, tau2)
//      |I - I'| is the mean absolute difference over the channels, G the
//      luma (Rec. 601, as MATLAB's rgb2gray) for LDR, log10-luminance
//      rescaled to [0,1] per pair for HDR (Eq. 4.2), or the normalised
//      radiance's luma for HDR with radiance gradients (Eq. 5.11). dx is
//      the central difference (x+1 - x-1) / 2, one-sided at the borders.
//      A pixel whose partner x - d falls outside the other image is
//      compared against the constant 3/255 (Hosni's reference code).
//   3. Aggregation: guided filter (colour guide = the view's own matching
//      image, r = 9, eps = 1e-4, BORDER_REFLECT box means); the guide
//      statistics (means, covariance inverse) are computed once per view
//      and reused for every slice.
//   4. Winner-takes-all while iterating the slices: only the running best
//      cost and label per pixel are kept (plus the neighbouring slices'
//      costs for sub-pixel refinement), never the W x H x D volume; ties go
//      to the smaller disparity. Steps 2-4 are one fused kernel that streams
//      row strips (split over threads) through cost, box filters and WTA
//      without full-size temporaries per slice (see the .cc).
//   5. Left-right check (both views computed): a left pixel is consistent
//      when |dL(x) - dR(x - dL(x))| <= lr_tolerance.
//   5a. Gain compensation (options.gain_compensation, needs the check):
//      per channel, the median ratio left / right over the consistent
//      matches that are textured (|dx G| >= tau2 in both views) and neither
//      dark nor clipped (values in [16/255, 240/255] in both). If a gain is
//      off 1 by more than 0.5 %, the right matching image is multiplied by
//      the gains (clipped to 1), the gradients are recomputed and steps 2-5
//      run once more; that second pass is kept if more pixels pass the
//      check. Why: the colour term's truncation (7/255) is a few percent of
//      mid-grey, so a gain or exposure difference of that size between the
//      views (2.6 % in G and R on Middlebury Cones) puts true matches on
//      the truncation (docs/results.md).
//   6. Inconsistent pixels get the lower of the nearest consistent
//      disparities to their left and right on the scanline.
//   7. Weighted median (bilateral weights, thesis Eq. 4.6) over the
//      (2 r + 1)^2 window, applied to the filled pixels only.
//   8. Optional sub-pixel refinement on consistent pixels: parabola
//      through the filtered costs at d - 1, d, d + 1.
//
// Disparities are positive for a left pixel x matching right pixel x - d.
#ifndef HDRSTEREO_PROCESSING_STEREO_COST_VOLUME_STEREO_H_
#define HDRSTEREO_PROCESSING_STEREO_COST_VOLUME_STEREO_H_

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::stereo {

enum class CostMode {
  kLdr,                  // Eq. 4.1: intensity + luma gradient
  kHdrLogLuminance,      // Eq. 4.2: radiance + log-luminance gradient
  kHdrRadianceGradient,  // Eq. 5.11: radiance + radiance (luma) gradient
};

struct StereoOptions {
  // Defaults for HDR radiance input: Eq. 4.2, white point at the 95th
  // percentile (clips light sources in view, which would otherwise squeeze
  // the scene into the bottom of [0,1]) and tau1 = 2/255 (linear radiance
  // differences are smaller than display-encoded ones). Chosen on the
  // simulator's lab-lamp scene; the thesis' LDR values otherwise.
  static StereoOptions Hdr() {
    StereoOptions o;
    o.mode = CostMode::kHdrLogLuminance;
    o.hdr_white_percentile = 95.0;
    o.tau_color = 2.0 / 255.0;
    return o;
  }

  int min_disparity = 0;   // inclusive
  int max_disparity = 64;  // inclusive; must be > min_disparity
  CostMode mode = CostMode::kLdr;
  // Weight of the colour term, as the thesis prints Eq. 4.1. Hosni et al.
  // put their 0.9 on the gradient term (alpha = 0.1 here): better on real
  // pairs without step 5a, worse on the simulated scenes (docs/results.md).
  double alpha = 0.9;
  double tau_color = 7.0 / 255.0;
  double tau_gradient = 2.0 / 255.0;
  int radius = 9;                // guided filter
  double eps = 1e-4;             // guided filter, on [0,1] data
  bool left_right_check = true;  // needs the right view (twice the work)
  int lr_tolerance = 0;          // |dL - dR| allowed, in labels
  bool fill = true;              // scanline fill of inconsistent pixels
  bool weighted_median = true;   // on the filled pixels
  int median_radius = 19;
  double sigma_s = 9.0;   // spatial sigma of Eq. 4.6, pixels
  double sigma_c = 0.1;   // colour sigma of Eq. 4.6, on [0,1] data
  bool subpixel = false;  // parabola fit on the filtered costs
  // Step 5a. Added for Middlebury Cones, the only real pair here (11.6 % ->
  // 2.5 % non-occluded bad-1px); its thresholds were fixed beforehand, not
  // tuned. The simulated views share one exposure: gains 1, no change.
  bool gain_compensation = true;
  // HDR: radiance is divided by this percentile of the pair's channel values
  // (100 = the maximum) and clipped to [0,1].
  double hdr_white_percentile = 100.0;
  int threads = 0;  // 0 = cv::getNumThreads()
};

// Images as the matcher sees them (step 1 and the gradient planes).
struct MatchingImages {
  cv::Mat left, right;            // CV_32FC1 or CV_32FC3, in [0,1]
  cv::Mat left_grad, right_grad;  // CV_32FC1, x-gradient of G
};

// The winner-takes-all result of one view.
struct WtaResult {
  cv::Mat labels;     // CV_32FC1, integer winning disparities
  cv::Mat disparity;  // CV_32FC1, labels refined if options.subpixel
  cv::Mat cost;       // CV_32FC1, filtered cost of the winner
};

struct StereoResult {
  cv::Mat disparity;   // CV_32FC1, left view, every pixel filled
  cv::Mat raw_left;    // CV_32FC1, left WTA labels
  cv::Mat raw_right;   // CV_32FC1, right WTA labels (if LR check)
  cv::Mat consistent;  // CV_8UC1, 255 where the LR check passed
  // Step 5a: the per-channel gain the right matching image was multiplied
  // by (1 where none was applied).
  cv::Scalar right_gain = cv::Scalar::all(1);
};

// Which view a slice/WTA is computed for.
enum class View { kLeft, kRight };

// Validates the pair and options; returns the [0,1] matching images.
// Errors (InvalidArgument): empty or 1-pixel images, different sizes or
// types, unsupported depth/channels, NaN/Inf, negative HDR radiance, an
// all-black HDR pair, max_disparity <= min_disparity, a range whose
// disparities reach past the image width, bad filter parameters.
absl::StatusOr<MatchingImages> PrepareMatchingImages(
    const cv::Mat& left, const cv::Mat& right, const StereoOptions& options);

// The unfiltered cost plane (Eq. 4.1/4.2) of disparity d for `view`:
// CV_32FC1 of the images' size. For the left view pixel x is compared with
// right pixel x - d; for the right view with left pixel x + d.
void ComputeCostSlice(const MatchingImages& images,
                      const StereoOptions& options, View view, int d,
                      cv::Mat& cost);

// The guided-filtered cost plane of disparity d for `view` (steps 2-3), as
// the WTA of ComputeWta sees it (CV_32FC1). For tests and diagnostics.
absl::StatusOr<cv::Mat> ComputeFilteredCostSlice(const MatchingImages& images,
                                                 const StereoOptions& options,
                                                 View view, int d);

// Filtered-cost WTA of one view (steps 2-4, plus 8 if options.subpixel).
absl::StatusOr<WtaResult> ComputeWta(const MatchingImages& images,
                                     const StereoOptions& options, View view);

// The full pipeline (steps 1-8).
absl::StatusOr<StereoResult> ComputeDisparity(
    const cv::Mat& left, const cv::Mat& right,
    const StereoOptions& options = {});

// Post-processing, usable on their own (e.g. by disparity fusion).
// Left-right check: CV_8UC1 mask, 255 where consistent. Both CV_32FC1.
cv::Mat LeftRightCheck(const cv::Mat& disp_left, const cv::Mat& disp_right,
                       float tolerance);
// Fills pixels where `valid` is 0 with the lower of the nearest valid
// values to the left and right on the same row (the one that exists if only
// one does; `fallback` if the row has none). In place, CV_32FC1.
void FillScanlines(cv::Mat& disparity, const cv::Mat& valid, float fallback);
// Weighted median (Eq. 4.6) of integer disparities in [dmin, dmax] at the
// pixels where `valid` is 0; guide CV_32FC1/C3 in [0,1]. Returns a copy.
cv::Mat WeightedMedian(const cv::Mat& disparity, const cv::Mat& valid,
                       const cv::Mat& guide, int dmin, int dmax, int radius,
                       double sigma_s, double sigma_c);

}  // namespace hdrstereo::stereo

#endif  // HDRSTEREO_PROCESSING_STEREO_COST_VOLUME_STEREO_H_
