// SPDX-License-Identifier: GPL-3.0-or-later
//
// Guided image filter (He, Sun & Tang, ECCV 2010 / TPAMI 2013).
//
// q = mean(a) * I + mean(b), with a, b the per-window linear coefficients
// that best explain the input p from the guide I (ridge term eps). Box means
// use cv::boxFilter with BORDER_REFLECT, so the exact filter reproduces
// cv::ximgproc::guidedFilter (tested to 1e-4 on [0,1] data).
//
// Reuse: the guide statistics (means, (co)variances and their inverse) are
// computed once in GuidedFilter::Create and reused by every Filter() call, so
// filtering many inputs with one guide (e.g. the slices of a stereo cost
// volume) costs only the input-dependent box filters.
//
// Fast path (He & Sun 2015, "Fast guided filter"): options.subsample = s > 1
// computes the coefficients on guide and input downsampled by s (INTER_AREA)
// with radius max(1, round(radius / s)), and upsamples mean(a), mean(b)
// bilinearly before applying them to the full-resolution guide. About s^2
// faster for the box filters; an approximation (not bit-compatible with the
// exact filter). The exact filter (s = 1) is the default.
#ifndef HDRSTEREO_PROCESSING_FILTERS_GUIDED_FILTER_H_
#define HDRSTEREO_PROCESSING_FILTERS_GUIDED_FILTER_H_

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::filters {

struct GuidedFilterOptions {
  int radius = 9;     // window is (2 radius + 1)^2 pixels
  double eps = 1e-4;  // ridge term, in squared guide units
  int subsample = 1;  // 1 = exact filter; s > 1 = fast guided filter

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const GuidedFilterOptions& o);

// Full-size scratch images of GuidedFilter::FilterPlane. Passing the same
// workspace to repeated calls (one workspace per thread) avoids allocating
// and page-faulting ~8 temporaries per call.
struct GuidedFilterWorkspace {
  cv::Mat low_src, mean_p, prod, mean_ip[3], ab[4], mean_ab[4], up[4];
};

class GuidedFilter {
 public:
  // guide: CV_8U or CV_32F, 1 or 3 channels, non-empty, finite. 8-bit guides
  // are used as is (0..255; scale eps accordingly) after conversion to float.
  static absl::StatusOr<GuidedFilter> Create(
      const cv::Mat& guide, const GuidedFilterOptions& options = {});

  // src: same size as the guide, CV_8U or CV_32F, any number of channels
  // (each filtered independently). Returns CV_32F with src's channels.
  absl::StatusOr<cv::Mat> Filter(const cv::Mat& src) const;

  // Hot-loop variant without validation: src must be CV_32FC1 of the guide's
  // size; dst is (re)allocated as CV_32FC1 (must not alias src). Never
  // throws for valid input. Thread-safe (the filter is not modified) as long
  // as each thread passes its own workspace (or none).
  void FilterPlane(const cv::Mat& src, cv::Mat& dst,
                   GuidedFilterWorkspace* workspace = nullptr) const;

  const GuidedFilterOptions& options() const { return options_; }
  cv::Size size() const { return full_guide_[0].size(); }
  int guide_channels() const { return static_cast<int>(full_guide_.size()); }

 private:
  GuidedFilter() = default;
  void Init(const cv::Mat& guide_float);
  cv::Mat Box(const cv::Mat& m) const;
  void BoxInto(const cv::Mat& m, cv::Mat& out) const;

  GuidedFilterOptions options_;
  int work_radius_ = 0;
  std::vector<cv::Mat> full_guide_;  // planes at full resolution
  std::vector<cv::Mat> guide_;       // planes at working resolution
  std::vector<cv::Mat> mean_guide_;  // box means of guide_ planes
  // 1 channel: inv_[0] = 1 / (var + eps).
  // 3 channels: symmetric inverse of (Sigma + eps I): rr, rg, rb, gg, gb, bb.
  std::vector<cv::Mat> inv_;
};

// One row of the per-pixel inverse of (Sigma + eps I) for a 3-channel
// guide, in closed form: `mean` are the box means of the guide's channels,
// `corr` the box means of their products and `inv` the symmetric inverse,
// both in the order rr, rg, rb, gg, gb, bb.
void InvertGuideCovarianceRow(const float* const mean[3],
                              const float* const corr[6], float eps, int width,
                              float* const inv[6]);

// One-shot convenience: GuidedFilter::Create(guide, options)->Filter(src).
absl::StatusOr<cv::Mat> ApplyGuidedFilter(
    const cv::Mat& guide, const cv::Mat& src,
    const GuidedFilterOptions& options = {});

}  // namespace hdrstereo::filters

#endif  // HDRSTEREO_PROCESSING_FILTERS_GUIDED_FILTER_H_
