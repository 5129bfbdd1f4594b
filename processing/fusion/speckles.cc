// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/speckles.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/fusion/fusion.h"

namespace hdrstereo::fusion {
namespace {

// filterSpeckles takes 16-bit disparities: values are stored x kSubpixel
// (as StereoSGBM's), fewer steps where the range would not fit.
constexpr int kSubpixel = 16;
constexpr int kMaxDisparity = std::numeric_limits<int16_t>::max() - 1;
constexpr int16_t kInvalid = -1;
// filterSpeckles keeps its wavefront in 16-bit coordinates.
constexpr int kMaxSide = std::numeric_limits<int16_t>::max();

}  // namespace

absl::Status SpeckleOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(max_size >= 0 && max_size <= 1e4, "max_size",
                               max_size, "in [0, 10000]"));
  return RequireField(max_step > 0 && max_step <= 100, "max_step", max_step,
                      "in (0, 100]");
}

void to_json(nlohmann::json& j, const SpeckleOptions& o) {
  const auto& [enabled, max_size, max_step] = o;
  j = nlohmann::json{
      {"enabled", enabled}, {"max_size", max_size}, {"max_step", max_step}};
}

absl::StatusOr<SpeckleResult> RemoveSpeckles(const cv::Mat& disparity,
                                             double tau, int max_disp,
                                             const SpeckleOptions& options) {
  RETURN_IF_ERROR(options.Validate());
  if (!(tau > 0) || !std::isfinite(tau)) {
    return absl::InvalidArgumentError(
        absl::StrCat("speckles: tau (", tau, ") must be positive and finite"));
  }
  if (max_disp < 1 || max_disp > kMaxDisparity) {
    return absl::InvalidArgumentError(
        absl::StrCat("speckles: max_disp (", max_disp, ") must be in [1, ",
                     kMaxDisparity, "]"));
  }
  if (disparity.empty() || disparity.type() != CV_32FC1) {
    return absl::InvalidArgumentError(
        "speckles: the disparity must be a CV_32FC1 map");
  }
  if (disparity.rows > kMaxSide || disparity.cols > kMaxSide) {
    return absl::InvalidArgumentError(
        absl::StrCat("speckles: the map is ", disparity.cols, " x ",
                     disparity.rows, "; at most ", kMaxSide, " px a side"));
  }
  const int scale = std::clamp(kMaxDisparity / (max_disp + 1), 1, kSubpixel);
  cv::Mat_<int16_t> regions(disparity.size());
  for (int y = 0; y < disparity.rows; ++y) {
    const float* z = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      regions(y, x) = IsValidDisparity(z[x], max_disp)
                          ? static_cast<int16_t>(std::lround(z[x] * scale))
                          : kInvalid;
    }
  }
  const double area =
      static_cast<double>(disparity.cols) * disparity.cols / (320.0 * 320.0);
  cv::filterSpeckles(regions, kInvalid,
                     static_cast<int>(std::lround(options.max_size * area)),
                     options.max_step * tau * scale);

  SpeckleResult result{disparity.clone(), 0};
  const float none = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> from_left(disparity.cols), from_right(disparity.cols);
  int64_t replaced = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* z = disparity.ptr<float>(y);
    auto kept = [&](int x) { return regions(y, x) != kInvalid ? z[x] : none; };
    float last = none;
    for (int x = 0; x < disparity.cols; ++x) {
      if (!std::isnan(kept(x))) last = kept(x);
      from_left[x] = last;
    }
    last = none;
    for (int x = disparity.cols - 1; x >= 0; --x) {
      if (!std::isnan(kept(x))) last = kept(x);
      from_right[x] = last;
    }
    float* out = result.disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      // Removed: valid before the filter, marked invalid by it.
      if (!IsValidDisparity(z[x], max_disp) || regions(y, x) != kInvalid) {
        continue;
      }
      // std::fmin: the one side with a kept value where the other has none.
      const float fill = std::fmin(from_left[x], from_right[x]);
      if (std::isnan(fill)) continue;
      out[x] = fill;
      ++replaced;
    }
  }
  result.replaced_fraction =
      static_cast<double>(replaced) / static_cast<double>(disparity.total());
  return result;
}

}  // namespace hdrstereo::fusion
