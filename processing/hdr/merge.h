// SPDX-License-Identifier: GPL-3.0-or-later
//
// HDR merge of an exposure stack into relative scene radiance (Debevec &
// Malik 1997, Eq. 6): ln E = sum_j w(Z_j) (g(Z_j) - ln dt_j) / sum_j w(Z_j).
// 8-bit input goes through per-channel lookup tables of weight and
// log-response and runs row-parallel; linear (16-bit/float) input is averaged
// as w(x) x / dt with a hat weight on the normalised value.
#ifndef HDRSTEREO_PROCESSING_HDR_MERGE_H_
#define HDRSTEREO_PROCESSING_HDR_MERGE_H_

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "absl/status/statusor.h"
#include "processing/hdr/response.h"
#include "processing/hdr/stack.h"

namespace hdrstereo::hdr {

// Bits of MergeResult::mask.
inline constexpr uint8_t kSaturatedEverywhere = 1;  // clipped high in all
inline constexpr uint8_t kDarkEverywhere = 2;       // clipped low in all

struct MergeOptions {
  // kLevels weights for 8-bit codes, for every channel; empty =
  // HatWeights(floor of the channel) with the response's floors. A code
  // with weight 0 is treated as clipped.
  std::vector<float> weights;
  // true: each channel is weighted by its own code (Debevec & Malik);
  // false: one weight per pixel, the mean of its channels' weights
  // (cv::MergeDebevec's convention).
  bool per_channel_weights = true;
  // Linear input: values at or above this fraction of full scale count as
  // saturated (weight 0).
  double linear_saturation = 0.98;
};

struct MergeResult {
  // CV_32FC3 (or C1) relative radiance: with an 8-bit response fixed at
  // g(128) = 0, a pixel reading code 128 at 1 s has radiance 1.
  cv::Mat radiance;
  // CV_8U per pixel: kSaturatedEverywhere where some channel was clipped
  // high in every exposure (it then holds the shortest exposure's clipped,
  // i.e. lower-bound, estimate), kDarkEverywhere where some channel was
  // clipped low in every exposure (longest exposure's estimate).
  cv::Mat mask;
  int saturated_pixels = 0;
  int dark_pixels = 0;
};

absl::StatusOr<MergeResult> MergeStack(const ExposureStack& stack,
                                       const CameraResponse& response,
                                       const MergeOptions& options = {});

// Rec. 709 luminance of a BGR radiance map (or the map itself if grey).
cv::Mat Luminance(const cv::Mat& radiance);

// log10 of luminance, with values below `floor` clamped to it ("log-HDR",
// thesis ch. 3 item 4).
cv::Mat LogLuminance(const cv::Mat& radiance, float floor = 1e-6f);

}  // namespace hdrstereo::hdr

#endif  // HDRSTEREO_PROCESSING_HDR_MERGE_H_
