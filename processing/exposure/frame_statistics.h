// SPDX-License-Identifier: GPL-3.0-or-later
//
// Exposure statistics of one 8-bit frame, per channel: the histogram of its
// 256 levels, the fractions of pixels clipped at either end, the mean, and
// the 1st, 50th and 99th percentiles. Live view sends them with every frame
// (Hardware.StreamPreview); the projector probe tells black frames from
// white ones by them.
//
//   absl::StatusOr<FrameStatistics> stats = ComputeFrameStatistics(bgr);
//   stats->channels[0].p99  // red: 99 % of the pixels are at or below it
#ifndef HDRSTEREO_PROCESSING_EXPOSURE_FRAME_STATISTICS_H_
#define HDRSTEREO_PROCESSING_EXPOSURE_FRAME_STATISTICS_H_

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::exposure {

inline constexpr int kLevels = 256;

struct ChannelStatistics {
  std::string name;  // "red", "green", "blue" or "gray"
  // histogram[v]: how many pixels have level v.
  std::array<int64_t, kLevels> histogram{};
  // Fractions of the pixels at level 0 (clipped low: black, or below the
  // sensor's black point) and at level 255 (clipped high: saturated).
  double clipped_low = 0;
  double clipped_high = 0;
  double mean = 0;
  // Percentiles by nearest rank: the lowest level v such that at least
  // ceil(q * pixels) pixels are at or below v (q = 0.01, 0.5, 0.99).
  int p1 = 0;
  int p50 = 0;
  int p99 = 0;
};

struct FrameStatistics {
  int width = 0;
  int height = 0;
  // Red, green, blue for a colour frame; one "gray" channel for a gray one.
  std::vector<ChannelStatistics> channels;

  // The mean level over every channel and pixel.
  double MeanLevel() const;
};

// Statistics of `image`: CV_8UC1 (gray) or CV_8UC3 (BGR, as OpenCV decodes
// colour images). INVALID_ARGUMENT for an empty image or any other type.
absl::StatusOr<FrameStatistics> ComputeFrameStatistics(const cv::Mat& image);
// The same of an encoded frame (JPEG, PNG, TIFF: what OpenCV decodes, as
// 8-bit BGR). DATA_LOSS when it cannot be decoded.
absl::StatusOr<FrameStatistics> ComputeEncodedFrameStatistics(
    absl::string_view bytes);

}  // namespace hdrstereo::exposure

#endif  // HDRSTEREO_PROCESSING_EXPOSURE_FRAME_STATISTICS_H_
