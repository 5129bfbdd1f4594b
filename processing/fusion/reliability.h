// SPDX-License-Identifier: GPL-3.0-or-later
//
// Fusion that weighs each candidate by its own evidence (docs/results.md,
// "Fusion that does not follow failing candidates").
//
// The thesis' fusion (fusion.h) trusts every candidate equally: where
// several tone-mapped pairs fail the same way it follows them, and at the
// rig's sizes it loses to the median of its own inputs. Here each
// candidate k gets, per pixel, a confidence in the data term:
//
//   e_k(p) = 1 where z_k(p) passed its left-right check and lies within
//            tau of the current estimate, else 0;
//   r_k(p) = (mean of e_k over a window of window_fraction x width
//            centred on p)^exponent;
//   c_k(p) = r_k(p) / max_j r_j(p)   (the best supported candidate there
//            keeps the full data weight; where no candidate has any
//            support in its window, every candidate keeps weight 1).
// Down-weighted candidates leave the data term weaker than the thesis'
// (one candidate at 1 and six near 0 is about 1/7 of it), so where the
// evidence points at one candidate the smoothness term counts for more.
//
// The estimate starts as the per-pixel median of the candidates that pass
// their left-right check there (of all where none does) and is
// replaced by the fused map after each pass (`passes` graph cuts in all):
// an alternation between the estimate and each source's local inlier rate,
// as in Dawid & Skene's (1979) estimation of observers' error rates and the
// inlier ratio of Vogiatzis & Hernandez's (2011) Gaussian + uniform depth
// model; the left-right check is the confidence measure Hu & Mordohai
// (2012) found among the most reliable.
//
// Then surfaces without texture take a plane (plane_prior.h), fitted to
// the fused pixels that at least two candidates passing their left-right
// check agree with (within tau); on textured surfaces, a candidate the
// views agree with clearly better than the fused value replaces it
// (photo_consistency.h: at depth edges the candidates' majority is often
// wrong); last, small islands of another surface's disparity are removed
// (speckles.h).
//
// Sizes are relative to the image: the data term's sigma and the agreement
// tolerance tau are both sigma_fraction x width (1 px at 320 px, where the
// thesis' sigma = 1 was measured), so candidates that agree at 320 px still
// agree at 1200 px, where the same surfaces have 3.75x the disparity.
#ifndef HDRSTEREO_PROCESSING_FUSION_RELIABILITY_H_
#define HDRSTEREO_PROCESSING_FUSION_RELIABILITY_H_

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "processing/fusion/fusion.h"
#include "processing/fusion/photo_consistency.h"
#include "processing/fusion/plane_prior.h"
#include "processing/fusion/speckles.h"

namespace hdrstereo::fusion {

// Defaults chosen on lab-lamp at 1200 px and checked on two-lamps and
// desk-lamp at 320 and 640 px (docs/results.md has the sweep).
struct ReliabilityOptions {
  bool enabled = true;  // false: the thesis' fusion, one cut (fusion.h)
  double sigma_fraction = 1.0 / 320;  // sigma and tau, times the width
  double window_fraction = 0.4;       // window side, times the width
  double exponent = 2.0;
  int passes = 3;  // graph cuts; the first from ConsistentMedian
  PlanePriorOptions planes;
  PhotoConsistencyOptions photo;
  SpeckleOptions speckles;

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const ReliabilityOptions& o);

// c_k of every candidate given the estimate (all CV_32FC1 of one size;
// consistent: one CV_8UC1 mask per candidate, non-zero = passed its
// left-right check, or empty = every pixel passed).
absl::StatusOr<std::vector<cv::Mat>> CandidateConfidences(
    const std::vector<cv::Mat>& candidates,
    const std::vector<cv::Mat>& consistent, const cv::Mat& estimate,
    const ReliabilityOptions& options);

// The first estimate: per pixel, the median of the candidates that passed
// their left-right check there, of all candidates where none did (or
// without masks); NaN where no candidate is valid.
absl::StatusOr<cv::Mat> ConsistentMedian(const std::vector<cv::Mat>& candidates,
                                         const std::vector<cv::Mat>& consistent,
                                         int max_disp);

// The fused pixels that at least two candidates which passed their
// left-right check agree with within tau (CV_8UC1, 255 = reliable).
absl::StatusOr<cv::Mat> ReliablePixels(const std::vector<cv::Mat>& candidates,
                                       const std::vector<cv::Mat>& consistent,
                                       const cv::Mat& fused, double tau);

// The passes above, then the plane prior, which segments `left`, the
// photo-consistency choice, which matches `left` against `right` (a
// tone-mapped pair, 8-bit, 1 or 3 channels, the candidates' size; unused
// when both steps are off), and the speckle filter. params.sigma is
// replaced by sigma_fraction x width. The disparity is integer labels
// except where a plane or a candidate's own value replaced them; the stats
// are the last pass' with total_seconds summed over all passes (the first
// estimate and the last three steps included); `refinement` counts what
// the last three steps changed.
absl::StatusOr<FusionResult> FuseByReliability(
    const std::vector<cv::Mat>& candidates,
    const std::vector<cv::Mat>& consistent, const cv::Mat& guide,
    const cv::Mat& left, const cv::Mat& right, FusionOptions params,
    const ReliabilityOptions& options);

}  // namespace hdrstereo::fusion

#endif  // HDRSTEREO_PROCESSING_FUSION_RELIABILITY_H_
