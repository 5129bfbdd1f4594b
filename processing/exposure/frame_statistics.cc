// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/exposure/frame_statistics.h"

#include <opencv2/imgcodecs.hpp>
#include <utility>

#include "absl/strings/str_cat.h"
#include "processing/io/image.h"

namespace hdrstereo::exposure {
namespace {

// The lowest level whose cumulative count reaches `rank` (1-based).
int LevelAtRank(const std::array<int64_t, kLevels>& histogram, int64_t rank) {
  int64_t seen = 0;
  for (int v = 0; v < kLevels; ++v) {
    seen += histogram[v];
    if (seen >= rank) return v;
  }
  return kLevels - 1;
}

// ceil(q * n) as a 1-based rank, at least 1: computed in integers for the
// percents used here so that e.g. 1 % of 300 pixels is rank 3 exactly.
int64_t Rank(int percent, int64_t n) {
  const int64_t rank = (percent * n + 99) / 100;
  return rank < 1 ? 1 : rank;
}

ChannelStatistics Summarize(const cv::Mat& plane, std::string name) {
  ChannelStatistics stats;
  stats.name = std::move(name);
  for (int y = 0; y < plane.rows; ++y) {
    const uchar* row = plane.ptr<uchar>(y);
    for (int x = 0; x < plane.cols; ++x) ++stats.histogram[row[x]];
  }
  const int64_t n = static_cast<int64_t>(plane.total());
  double sum = 0;
  for (int v = 0; v < kLevels; ++v) sum += double(v) * stats.histogram[v];
  stats.mean = sum / double(n);
  stats.clipped_low = double(stats.histogram[0]) / double(n);
  stats.clipped_high = double(stats.histogram[kLevels - 1]) / double(n);
  stats.p1 = LevelAtRank(stats.histogram, Rank(1, n));
  stats.p50 = LevelAtRank(stats.histogram, Rank(50, n));
  stats.p99 = LevelAtRank(stats.histogram, Rank(99, n));
  return stats;
}

}  // namespace

double FrameStatistics::MeanLevel() const {
  if (channels.empty()) return 0;
  double sum = 0;
  for (const ChannelStatistics& c : channels) sum += c.mean;
  return sum / double(channels.size());
}

absl::StatusOr<FrameStatistics> ComputeFrameStatistics(const cv::Mat& image) {
  if (image.empty() || (image.type() != CV_8UC1 && image.type() != CV_8UC3)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "frame statistics need an 8-bit gray or BGR image, not ",
        image.empty() ? "an empty one"
                      : absl::StrCat("OpenCV type ", image.type())));
  }
  FrameStatistics stats;
  stats.width = image.cols;
  stats.height = image.rows;
  if (image.channels() == 1) {
    stats.channels.push_back(Summarize(image, "gray"));
    return stats;
  }
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  stats.channels.push_back(Summarize(planes[2], "red"));
  stats.channels.push_back(Summarize(planes[1], "green"));
  stats.channels.push_back(Summarize(planes[0], "blue"));
  return stats;
}

absl::StatusOr<FrameStatistics> ComputeEncodedFrameStatistics(
    absl::string_view bytes) {
  absl::StatusOr<cv::Mat> image = io::DecodeWithOpenCv(bytes, cv::IMREAD_COLOR);
  if (!image.ok()) {
    return absl::DataLossError(
        absl::StrCat("a frame of ", bytes.size(),
                     " bytes cannot be decoded: ", image.status().message()));
  }
  return ComputeFrameStatistics(*image);
}

}  // namespace hdrstereo::exposure
