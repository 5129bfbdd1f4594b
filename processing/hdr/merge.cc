// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/hdr/merge.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::hdr {
namespace {

constexpr int kMaxChannels = 3;

// Indices of the shortest and longest exposures.
std::pair<int, int> ShortestLongest(const std::vector<double>& t) {
  int shortest = 0, longest = 0;
  for (int j = 1; j < static_cast<int>(t.size()); ++j) {
    if (t[j] < t[shortest]) shortest = j;
    if (t[j] > t[longest]) longest = j;
  }
  return {shortest, longest};
}

absl::StatusOr<MergeResult> Merge8(const ExposureStack& stack,
                                   const CameraResponse& response,
                                   const MergeOptions& options) {
  const int n = static_cast<int>(stack.images.size());
  const int ch = stack.images[0].channels();
  const int rows = stack.images[0].rows, cols = stack.images[0].cols;
  if (response.log_inverse.rows != kLevels ||
      (response.log_inverse.channels() != ch &&
       response.log_inverse.channels() != 1) ||
      response.log_inverse.depth() != CV_32F) {
    return absl::InvalidArgumentError(absl::StrCat(
        "camera response has ", response.log_inverse.channels(), " channels/",
        response.log_inverse.rows, " levels; the stack (", stack.Name(0),
        ") has ", ch, " channels of 8-bit codes"));
  }
  // options.Validate() has checked the number of weights.
  if (!response.floor.empty() &&
      static_cast<int>(response.floor.size()) != ch) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera response has code floors for ",
                     response.floor.size(), " channels; the stack has ", ch));
  }
  // weight[c * kLevels + z]
  std::vector<float> weight;
  for (int c = 0; c < ch; ++c) {
    const std::vector<float> wc =
        !options.weights.empty()
            ? options.weights
            : HatWeights(response.floor.empty() ? 0 : response.floor[c]);
    weight.insert(weight.end(), wc.begin(), wc.end());
  }
  // LUTs: weight[c][z] and, per exposure, logE[j][c][z] = g_c(z) - ln dt_j.
  const int rch = response.log_inverse.channels();
  std::vector<float> log_e(static_cast<size_t>(n) * kMaxChannels * kLevels);
  for (int j = 0; j < n; ++j) {
    const float ln_dt = static_cast<float>(std::log(stack.exposure_s[j]));
    for (int c = 0; c < ch; ++c) {
      for (int z = 0; z < kLevels; ++z) {
        log_e[(j * kMaxChannels + c) * kLevels + z] =
            response.log_inverse.ptr<float>(z)[rch == 1 ? 0 : c] - ln_dt;
      }
    }
  }
  const auto [shortest, longest] = ShortestLongest(stack.exposure_s);
  MergeResult out;
  out.radiance.create(rows, cols, CV_32FC(ch));
  out.mask.create(rows, cols, CV_8U);
  std::atomic<int> saturated{0}, dark{0};
  const bool per_channel = options.per_channel_weights || ch == 1;

  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    const int len = cols * ch;
    std::vector<float> num(len), den(len);
    std::vector<float> pixel_w(cols);
    int local_sat = 0, local_dark = 0;
    for (int y = range.start; y < range.end; ++y) {
      std::fill(num.begin(), num.end(), 0.f);
      std::fill(den.begin(), den.end(), 0.f);
      for (int j = 0; j < n; ++j) {
        const uint8_t* src = stack.images[j].ptr<uint8_t>(y);
        const float* lut =
            &log_e[static_cast<size_t>(j) * kMaxChannels * kLevels];
        if (per_channel) {
          for (int x = 0; x < cols; ++x) {
            for (int c = 0; c < ch; ++c) {
              const int i = x * ch + c;
              const uint8_t z = src[i];
              const float wz = weight[c * kLevels + z];
              num[i] += wz * lut[c * kLevels + z];
              den[i] += wz;
            }
          }
        } else {
          const float inv = 1.0f / ch;
          for (int x = 0; x < cols; ++x) {
            const uint8_t* p = src + x * ch;
            float wz = 0;
            for (int c = 0; c < ch; ++c) wz += weight[c * kLevels + p[c]];
            wz *= inv;
            for (int c = 0; c < ch; ++c) {
              num[x * ch + c] += wz * lut[c * kLevels + p[c]];
              den[x * ch + c] += wz;
            }
          }
        }
      }
      float* dst = out.radiance.ptr<float>(y);
      uint8_t* mask = out.mask.ptr<uint8_t>(y);
      std::fill(mask, mask + cols, uint8_t{0});
      const uint8_t* short_row = stack.images[shortest].ptr<uint8_t>(y);
      const uint8_t* long_row = stack.images[longest].ptr<uint8_t>(y);
      for (int i = 0; i < len; ++i) {
        if (den[i] > 0) {
          dst[i] = num[i] / den[i];
        } else if (short_row[i] >= kLevels / 2) {
          const int c = i % ch;
          dst[i] =
              log_e[(shortest * kMaxChannels + c) * kLevels + short_row[i]];
          mask[i / ch] |= kSaturatedEverywhere;
        } else {
          const int c = i % ch;
          dst[i] = log_e[(longest * kMaxChannels + c) * kLevels + long_row[i]];
          mask[i / ch] |= kDarkEverywhere;
        }
      }
      for (int x = 0; x < cols; ++x) {
        local_sat += (mask[x] & kSaturatedEverywhere) != 0;
        local_dark += (mask[x] & kDarkEverywhere) != 0;
      }
      cv::Mat row(1, len, CV_32F, dst);
      cv::exp(row, row);
    }
    saturated += local_sat;
    dark += local_dark;
  });
  out.saturated_pixels = saturated;
  out.dark_pixels = dark;
  return out;
}

absl::StatusOr<MergeResult> MergeLinear(const ExposureStack& stack,
                                        const MergeOptions& options) {
  const int n = static_cast<int>(stack.images.size());
  const int ch = stack.images[0].channels();
  const int rows = stack.images[0].rows, cols = stack.images[0].cols;
  const int depth = stack.images[0].depth();
  const float scale = depth == CV_8U    ? 1.f / 255
                      : depth == CV_16U ? 1.f / 65535
                                        : 1.f;
  const float sat = static_cast<float>(options.linear_saturation);
  const auto [shortest, longest] = ShortestLongest(stack.exposure_s);
  std::vector<cv::Mat> f(n);
  for (int j = 0; j < n; ++j) stack.images[j].convertTo(f[j], CV_32F, scale);
  MergeResult out;
  out.radiance.create(rows, cols, CV_32FC(ch));
  out.mask.create(rows, cols, CV_8U);
  std::atomic<int> saturated{0}, dark{0};
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    const int len = cols * ch;
    std::vector<float> num(len), den(len);
    int local_sat = 0, local_dark = 0;
    for (int y = range.start; y < range.end; ++y) {
      std::fill(num.begin(), num.end(), 0.f);
      std::fill(den.begin(), den.end(), 0.f);
      for (int j = 0; j < n; ++j) {
        const float* src = f[j].ptr<float>(y);
        const float inv_t = static_cast<float>(1.0 / stack.exposure_s[j]);
        for (int i = 0; i < len; ++i) {
          const float v = src[i];
          // Hat on [0, sat]: rises to the middle, 0 at and above saturation.
          float wv = v >= sat || v <= 0 ? 0.f : std::min(v, sat - v);
          num[i] += wv * v * inv_t;
          den[i] += wv;
        }
      }
      float* dst = out.radiance.ptr<float>(y);
      uint8_t* mask = out.mask.ptr<uint8_t>(y);
      std::fill(mask, mask + cols, uint8_t{0});
      for (int i = 0; i < len; ++i) {
        if (den[i] > 0) {
          dst[i] = num[i] / den[i];
          continue;
        }
        const float vs = f[shortest].ptr<float>(y)[i];
        if (vs >= 0.5f) {
          dst[i] = vs / static_cast<float>(stack.exposure_s[shortest]);
          mask[i / ch] |= kSaturatedEverywhere;
        } else {
          dst[i] = f[longest].ptr<float>(y)[i] /
                   static_cast<float>(stack.exposure_s[longest]);
          mask[i / ch] |= kDarkEverywhere;
        }
      }
      for (int x = 0; x < cols; ++x) {
        local_sat += (mask[x] & kSaturatedEverywhere) != 0;
        local_dark += (mask[x] & kDarkEverywhere) != 0;
      }
    }
    saturated += local_sat;
    dark += local_dark;
  });
  out.saturated_pixels = saturated;
  out.dark_pixels = dark;
  return out;
}

}  // namespace

absl::StatusOr<MergeResult> MergeStack(const ExposureStack& stack,
                                       const CameraResponse& response,
                                       const MergeOptions& options) {
  RETURN_IF_ERROR(ValidateStack(stack));
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("merge: ", s.message()));
  }
  try {
    if (response.linear) return MergeLinear(stack, options);
    if (stack.images[0].depth() != CV_8U) {
      return absl::InvalidArgumentError(absl::StrCat(
          "a tabulated camera response needs 8-bit images; ", stack.Name(0),
          " is not 8-bit (use LinearResponse() for linear RAW data)"));
    }
    return Merge8(stack, response, options);
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("HDR merge failed: ", e.what()));
  }
}

cv::Mat Luminance(const cv::Mat& radiance) {
  if (radiance.channels() == 1) {
    cv::Mat f;
    radiance.convertTo(f, CV_32F);
    return f;
  }
  cv::Mat y;
  cv::transform(radiance, y, cv::Matx13f(0.0722f, 0.7152f, 0.2126f));
  return y;
}

cv::Mat LogLuminance(const cv::Mat& radiance, float floor) {
  cv::Mat y = cv::max(Luminance(radiance), floor);
  cv::Mat out;
  cv::log(y, out);
  return out * static_cast<float>(1.0 / std::log(10.0));
}

}  // namespace hdrstereo::hdr
