// SPDX-License-Identifier: GPL-3.0-or-later
//
// Frame statistics on synthetic images whose histogram, clipping and
// percentiles are known exactly.
#include "processing/exposure/frame_statistics.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "tests/support/status_matchers.h"

namespace hdrstereo::exposure {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

// A 10 x 10 gray ramp: pixel i (row-major) has level i, so every level
// 0..99 occurs once.
cv::Mat Ramp100() {
  cv::Mat image(10, 10, CV_8UC1);
  for (int i = 0; i < 100; ++i) image.at<uchar>(i / 10, i % 10) = uchar(i);
  return image;
}

TEST(FrameStatisticsTest, GrayRampHasOnePixelPerLevel) {
  ASSERT_OK_AND_ASSIGN(FrameStatistics stats,
                       ComputeFrameStatistics(Ramp100()));
  EXPECT_EQ(stats.width, 10);
  EXPECT_EQ(stats.height, 10);
  ASSERT_EQ(stats.channels.size(), 1u);
  const ChannelStatistics& gray = stats.channels[0];
  EXPECT_EQ(gray.name, "gray");
  for (int v = 0; v < kLevels; ++v) {
    EXPECT_EQ(gray.histogram[v], v < 100 ? 1 : 0) << "level " << v;
  }
  // Nearest rank over 100 pixels: rank 1 -> 0, rank 50 -> 49, rank 99 -> 98.
  EXPECT_EQ(gray.p1, 0);
  EXPECT_EQ(gray.p50, 49);
  EXPECT_EQ(gray.p99, 98);
  EXPECT_DOUBLE_EQ(gray.clipped_low, 0.01);  // the one pixel at 0
  EXPECT_DOUBLE_EQ(gray.clipped_high, 0.0);
  EXPECT_DOUBLE_EQ(gray.mean, 49.5);
  EXPECT_DOUBLE_EQ(stats.MeanLevel(), 49.5);
}

TEST(FrameStatisticsTest, PercentilesRoundTheRankUp) {
  // 300 pixels: 2 at 10, 148 at 20, 147 at 200, 3 at 255. Rank ceil(0.01 *
  // 300) = 3 is the first pixel at 20; rank 150 the last at 20; rank 297
  // the last at 200.
  cv::Mat image(1, 300, CV_8UC1);
  for (int i = 0; i < 300; ++i) {
    image.at<uchar>(0, i) = i < 2 ? 10 : i < 150 ? 20 : i < 297 ? 200 : 255;
  }
  ASSERT_OK_AND_ASSIGN(FrameStatistics stats, ComputeFrameStatistics(image));
  const ChannelStatistics& gray = stats.channels[0];
  EXPECT_EQ(gray.p1, 20);
  EXPECT_EQ(gray.p50, 20);
  EXPECT_EQ(gray.p99, 200);
  EXPECT_DOUBLE_EQ(gray.clipped_high, 3.0 / 300);
  EXPECT_DOUBLE_EQ(gray.clipped_low, 0.0);
  EXPECT_DOUBLE_EQ(gray.mean,
                   (2 * 10 + 148 * 20 + 147 * 200 + 3 * 255) / 300.0);
}

TEST(FrameStatisticsTest, ColourChannelsAreReportedRedGreenBlue) {
  // BGR: blue saturated in the left half, red black everywhere, green a
  // constant 77.
  cv::Mat image(4, 8, CV_8UC3, cv::Scalar(0, 77, 0));
  image(cv::Rect(0, 0, 4, 4)).setTo(cv::Scalar(255, 77, 0));
  ASSERT_OK_AND_ASSIGN(FrameStatistics stats, ComputeFrameStatistics(image));
  ASSERT_EQ(stats.channels.size(), 3u);
  const ChannelStatistics& red = stats.channels[0];
  const ChannelStatistics& green = stats.channels[1];
  const ChannelStatistics& blue = stats.channels[2];
  EXPECT_EQ(red.name, "red");
  EXPECT_EQ(green.name, "green");
  EXPECT_EQ(blue.name, "blue");
  EXPECT_DOUBLE_EQ(red.clipped_low, 1.0);
  EXPECT_EQ(red.histogram[0], 32);
  EXPECT_EQ(red.p99, 0);
  EXPECT_EQ(green.histogram[77], 32);
  EXPECT_EQ(green.p1, 77);
  EXPECT_EQ(green.p99, 77);
  EXPECT_DOUBLE_EQ(green.clipped_low, 0.0);
  EXPECT_DOUBLE_EQ(blue.clipped_high, 0.5);
  EXPECT_DOUBLE_EQ(blue.clipped_low, 0.5);
  EXPECT_EQ(blue.p1, 0);
  EXPECT_EQ(blue.p50, 0);  // rank 16 is the last black pixel
  EXPECT_EQ(blue.p99, 255);
  EXPECT_DOUBLE_EQ(blue.mean, 127.5);
  EXPECT_DOUBLE_EQ(stats.MeanLevel(), (0 + 77 + 127.5) / 3);
}

TEST(FrameStatisticsTest, OneWhitePixelIsAboveTheNinetyNinthPercentile) {
  // 100 pixels at 100, one raised to 255: 1 % clipped high, yet the 99th
  // percentile (rank 99) stays at 100.
  cv::Mat image(10, 10, CV_8UC1, cv::Scalar(100));
  image.at<uchar>(3, 7) = 255;
  ASSERT_OK_AND_ASSIGN(FrameStatistics stats, ComputeFrameStatistics(image));
  EXPECT_EQ(stats.channels[0].p99, 100);
  EXPECT_DOUBLE_EQ(stats.channels[0].clipped_high, 0.01);
}

TEST(FrameStatisticsTest, RefusesWhatIsNotEightBitGrayOrBgr) {
  EXPECT_THAT(ComputeFrameStatistics(cv::Mat()),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("not an empty one")));
  EXPECT_THAT(ComputeFrameStatistics(cv::Mat(2, 2, CV_16UC1)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("8-bit gray or BGR")));
  EXPECT_THAT(ComputeFrameStatistics(cv::Mat(2, 2, CV_8UC4)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("OpenCV type 24")));
}

TEST(FrameStatisticsTest, EncodedFramesAreDecodedToEightBitBgr) {
  // PNG is lossless: the statistics of the file are those of the image.
  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", Ramp100(), png));
  ASSERT_OK_AND_ASSIGN(
      FrameStatistics stats,
      ComputeEncodedFrameStatistics(absl::string_view(
          reinterpret_cast<const char*>(png.data()), png.size())));
  // A gray file decodes to three equal channels.
  ASSERT_EQ(stats.channels.size(), 3u);
  for (const ChannelStatistics& c : stats.channels) {
    EXPECT_EQ(c.p50, 49) << c.name;
    EXPECT_DOUBLE_EQ(c.mean, 49.5) << c.name;
  }
  EXPECT_THAT(ComputeEncodedFrameStatistics("not an image"),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("a frame of 12 bytes cannot be decoded")));
}

}  // namespace
}  // namespace hdrstereo::exposure
