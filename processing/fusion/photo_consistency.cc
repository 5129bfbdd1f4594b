// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/fusion/photo_consistency.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/fusion/fusion.h"
#include "processing/fusion/texture.h"

namespace hdrstereo::fusion {
namespace {

// More candidates than this per pixel are refused (the fusion has seven).
constexpr size_t kMaxCandidates = 64;
// Disparities are costed as ints (x - d): far below INT_MAX.
constexpr int kMaxDisparity = 1 << 20;

// The left view's texture: per pixel, the mean gradient magnitude (grey
// levels per pixel) over the (2r + 1)^2 window.
cv::Mat WindowTexture(const cv::Mat& left, int radius) {
  cv::Mat texture;
  cv::blur(GradientMagnitude(left), texture,
           cv::Size(2 * radius + 1, 2 * radius + 1));
  return texture;
}

// How many candidates are within tau of z at (x, y) (NaN: none).
int Agreeing(const std::vector<cv::Mat>& candidates, int y, int x, float z,
             double tau) {
  int n = 0;
  for (const cv::Mat& c : candidates) {
    if (std::abs(c.ptr<float>(y)[x] - z) <= tau) ++n;
  }
  return n;
}

// C(p, d) of the header for one pixel: Centre(x, y) computes its window's
// weights, then At(d) costs each label. Holds references to the views: a
// local of the loop that uses it.
class WindowCost {
 public:
  WindowCost(const cv::Mat& left, const cv::Mat& right, int radius,
             const PhotoConsistencyOptions& o)
      : left_(left),
        right_(right),
        radius_(radius),
        side_(2 * radius + 1),
        channels_(left.channels()),
        truncation_(static_cast<float>(o.truncation)),
        inverse_sigma_(static_cast<float>(1.0 / o.colour_sigma)) {
    spatial_.resize(static_cast<size_t>(side_ * side_));
    weights_.resize(spatial_.size());
    for (int dy = -radius; dy <= radius; ++dy) {
      for (int dx = -radius; dx <= radius; ++dx) {
        spatial_[Index(dx, dy)] =
            static_cast<float>(std::exp(-std::hypot(dx, dy) / radius));
      }
    }
  }

  // The support weights of the window centred on (x, y) (0 outside).
  void Centre(int x, int y) {
    x_ = x;
    y_ = y;
    const float* p = Left(y, x);
    for (int dy = -radius_; dy <= radius_; ++dy) {
      for (int dx = -radius_; dx <= radius_; ++dx) {
        const size_t i = Index(dx, dy);
        const int qy = y + dy, qx = x + dx;
        if (qy < 0 || qy >= left_.rows || qx < 0 || qx >= left_.cols) {
          weights_[i] = 0;
          continue;
        }
        const float* q = Left(qy, qx);
        float difference = 0;
        for (int c = 0; c < channels_; ++c) difference += std::abs(q[c] - p[c]);
        weights_[i] = spatial_[i] * std::exp(-difference * inverse_sigma_);
      }
    }
  }

  // Infinity when no window pixel has a partner in the right view.
  float At(int d) const {
    float sum = 0, weight = 0;
    for (int dy = -radius_; dy <= radius_; ++dy) {
      const int qy = y_ + dy;
      if (qy < 0 || qy >= left_.rows) continue;
      for (int dx = -radius_; dx <= radius_; ++dx) {
        const int qx = x_ + dx, rx = qx - d;
        const float w = weights_[Index(dx, dy)];
        if (w == 0 || rx < 0 || rx >= right_.cols) continue;
        const float* l = Left(qy, qx);
        const float* r = right_.ptr<float>(qy) + rx * channels_;
        float difference = 0;
        for (int c = 0; c < channels_; ++c) difference += std::abs(l[c] - r[c]);
        sum += w * std::min(difference / channels_, truncation_);
        weight += w;
      }
    }
    return weight > 0 ? sum / weight : std::numeric_limits<float>::infinity();
  }

 private:
  // The window offset (dx, dy)'s place in spatial_ and weights_.
  size_t Index(int dx, int dy) const {
    return static_cast<size_t>((dy + radius_) * side_ + dx + radius_);
  }

  const float* Left(int y, int x) const {
    return left_.ptr<float>(y) + x * channels_;
  }

  const cv::Mat& left_;
  const cv::Mat& right_;
  const int radius_;
  const int side_;
  const int channels_;
  const float truncation_;
  const float inverse_sigma_;
  std::vector<float> spatial_, weights_;
  int x_ = 0, y_ = 0;
};

}  // namespace

absl::Status PhotoConsistencyOptions::Validate() const {
  RETURN_IF_ERROR(RequireField(window_radius >= 1 && window_radius <= 32,
                               "window_radius", window_radius, "in [1, 32]"));
  RETURN_IF_ERROR(RequireField(colour_sigma > 0 && colour_sigma <= 10,
                               "colour_sigma", colour_sigma, "in (0, 10]"));
  RETURN_IF_ERROR(RequireField(truncation > 0 && truncation <= 1, "truncation",
                               truncation, "in (0, 1]"));
  RETURN_IF_ERROR(RequireField(min_texture >= 0 && min_texture <= 255,
                               "min_texture", min_texture, "in [0, 255]"));
  RETURN_IF_ERROR(RequireField(max_cost_ratio > 0 && max_cost_ratio <= 1,
                               "max_cost_ratio", max_cost_ratio, "in (0, 1]"));
  return RequireField(
      min_agreeing >= 1 && min_agreeing <= static_cast<int>(kMaxCandidates),
      "min_agreeing", min_agreeing, "in [1, 64]");
}

void to_json(nlohmann::json& j, const PhotoConsistencyOptions& o) {
  const auto& [enabled, window_radius, colour_sigma, truncation, min_texture,
               max_cost_ratio, min_agreeing] = o;
  j = nlohmann::json{
      {"enabled", enabled},           {"window_radius", window_radius},
      {"colour_sigma", colour_sigma}, {"truncation", truncation},
      {"min_texture", min_texture},   {"max_cost_ratio", max_cost_ratio},
      {"min_agreeing", min_agreeing}};
}

absl::StatusOr<PhotoConsistencyResult> ChooseByPhotoConsistency(
    const cv::Mat& disparity, const std::vector<cv::Mat>& candidates,
    const cv::Mat& left, const cv::Mat& right, double tau, int max_disp,
    const PhotoConsistencyOptions& options) {
  RETURN_IF_ERROR(options.Validate());
  if (!(tau > 0) || max_disp < 1 || max_disp > kMaxDisparity) {
    return absl::InvalidArgumentError(absl::StrCat(
        "photo-consistency: tau (", tau, ") must be positive and max_disp (",
        max_disp, ") in [1, ", kMaxDisparity, "]"));
  }
  if (disparity.empty() || disparity.type() != CV_32FC1) {
    return absl::InvalidArgumentError(
        "photo-consistency: the disparity must be a CV_32FC1 map");
  }
  const cv::Size size = disparity.size();
  if (candidates.empty() || candidates.size() > kMaxCandidates) {
    return absl::InvalidArgumentError(
        absl::StrCat("photo-consistency: ", candidates.size(),
                     " candidates; 1 to ", kMaxCandidates, " are allowed"));
  }
  if (static_cast<size_t>(options.min_agreeing) > candidates.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("photo-consistency: min_agreeing (", options.min_agreeing,
                     ") exceeds the ", candidates.size(), " candidates"));
  }
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (candidates[k].type() != CV_32FC1 || candidates[k].size() != size) {
      return absl::InvalidArgumentError(
          absl::StrCat("photo-consistency: candidate ", k,
                       " must be CV_32FC1 of the map's size"));
    }
  }
  const auto is_view = [&](const cv::Mat& v) {
    return (v.type() == CV_8UC1 || v.type() == CV_8UC3) && v.size() == size;
  };
  if (!is_view(left) || !is_view(right) || left.type() != right.type()) {
    return absl::InvalidArgumentError(
        "photo-consistency: the views must be a pair of 8-bit images, 1 or 3 "
        "channels, of the map's size");
  }
  const int radius =
      std::max(1, static_cast<int>(
                      std::lround(options.window_radius * size.width / 320.0)));
  cv::Mat left_f, right_f;
  left.convertTo(left_f, CV_32F, 1.0 / 255.0);
  right.convertTo(right_f, CV_32F, 1.0 / 255.0);
  const cv::Mat texture = WindowTexture(left, radius);

  PhotoConsistencyResult result;
  result.disparity = disparity.clone();
  std::atomic<int64_t> replaced{0};
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    WindowCost cost(left_f, right_f, radius, options);
    std::vector<int> labels;
    int64_t local = 0;
    for (int y = rows.start; y < rows.end; ++y) {
      const float* fused = disparity.ptr<float>(y);
      const float* t = texture.ptr<float>(y);
      float* out = result.disparity.ptr<float>(y);
      for (int x = 0; x < size.width; ++x) {
        if (t[x] < options.min_texture ||
            !IsValidDisparity(fused[x], max_disp)) {
          continue;
        }
        // Each rounded label is costed once: the fused value's only when
        // some candidate proposes another label, then each new one.
        labels.assign(1, static_cast<int>(std::lround(fused[x])));
        float best_cost = 0;
        int best = -1;
        for (size_t k = 0; k < candidates.size(); ++k) {
          const float z = candidates[k].ptr<float>(y)[x];
          if (!IsValidDisparity(z, max_disp)) continue;
          const int label = static_cast<int>(std::lround(z));
          if (std::find(labels.begin(), labels.end(), label) != labels.end() ||
              Agreeing(candidates, y, x, z, tau) < options.min_agreeing) {
            continue;
          }
          if (labels.size() == 1) {
            cost.Centre(x, y);
            const float own = cost.At(labels[0]);
            // Kept where the fused value has no partner in the right view
            // (no evidence either way) or matches exactly.
            if (!std::isfinite(own) || own == 0) break;
            best_cost = own * static_cast<float>(options.max_cost_ratio);
          }
          labels.push_back(label);
          const float c = cost.At(label);
          if (c < best_cost) {
            best_cost = c;
            best = static_cast<int>(k);
          }
        }
        if (best >= 0) {
          out[x] = candidates[static_cast<size_t>(best)].ptr<float>(y)[x];
          ++local;
        }
      }
    }
    replaced += local;
  });
  result.replaced_fraction =
      static_cast<double>(replaced.load()) / static_cast<double>(size.area());
  return result;
}

}  // namespace hdrstereo::fusion
