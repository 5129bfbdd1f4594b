// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/filters/domain_transform.h"

#include <opencv2/ximgproc/edge_filter.hpp>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/filters/mat_checks.h"

namespace hdrstereo::filters {

absl::StatusOr<cv::Mat> DomainTransformFilter(
    const cv::Mat& src, const cv::Mat& guide,
    const DomainTransformOptions& options) {
  RETURN_IF_ERROR(
      CheckImage(src, "domain transform input", /*float_only=*/false, {}));
  const cv::Mat& g = guide.empty() ? src : guide;
  RETURN_IF_ERROR(
      CheckImage(g, "domain transform guide", /*float_only=*/false, {1, 3}));
  if (g.size() != src.size()) {
    return absl::InvalidArgumentError(
        "domain transform input and guide differ in size");
  }
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("domain transform: ", s.message()));
  }
  try {
    // The filter object holds the guide's transformed distances, so every
    // plane reuses them.
    const cv::Ptr<cv::ximgproc::DTFilter> filter =
        cv::ximgproc::createDTFilter(g, options.sigma_s, options.sigma_r,
                                     cv::ximgproc::DTF_RF, options.iterations);
    cv::Mat out;
    // OpenCV filters up to 4 channels at once; more go plane by plane.
    if (src.channels() <= 4) {
      filter->filter(src, out, CV_32F);
      return out;
    }
    std::vector<cv::Mat> planes;
    cv::split(src, planes);
    for (cv::Mat& p : planes) {
      cv::Mat filtered;
      filter->filter(p, filtered, CV_32F);
      p = filtered;
    }
    cv::merge(planes, out);
    return out;
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("domain transform: ", e.what()));
  }
}

}  // namespace hdrstereo::filters
