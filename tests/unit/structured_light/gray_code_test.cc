// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/structured_light/gray_code.h"

#include <gtest/gtest.h>

#include <set>

namespace hdrstereo::structured_light {
namespace {

TEST(GrayCodeTest, BitCounts) {
  EXPECT_EQ(BitCount(1024), 10);
  EXPECT_EQ(BitCount(768), 10);
  EXPECT_EQ(BitCount(1025), 11);
  EXPECT_EQ(BitCount(2), 1);
}

TEST(GrayCodeTest, NeighboursDifferInOneBitAndInverseRoundTrips) {
  for (int i = 0; i < 4096; ++i) {
    EXPECT_EQ(FromGray(ToGray(i)), i);
    EXPECT_EQ(__builtin_popcount(ToGray(i) ^ ToGray(i + 1)), 1) << i;
  }
}

TEST(GrayCodeTest, FortyTwoPatternsAt1024x768WithUniqueIds) {
  std::vector<Pattern> patterns = AllPatterns({1024, 768});
  ASSERT_EQ(patterns.size(), 42u);
  std::set<std::string> ids;
  for (const Pattern& p : patterns) {
    ids.insert(p.Id() + (p.inverse ? "_inv" : ""));
  }
  EXPECT_EQ(ids.size(), 42u);
  EXPECT_EQ(patterns.front().Id(), "col_b00");
  EXPECT_EQ(patterns[20].Id(), "row_b00");
  EXPECT_EQ(patterns.back().Id(), "black");
}

// Decoding every rendered bit plane by hand recovers each column and row:
// the patterns code what they claim to.
TEST(GrayCodeTest, RenderedPlanesDecodeToColumnAndRow) {
  const cv::Size size(100, 60);  // not powers of two on purpose
  cv::Mat column_gray(size, CV_32SC1, cv::Scalar(0));
  cv::Mat row_gray(size, CV_32SC1, cv::Scalar(0));
  for (const Pattern& p : AllPatterns(size)) {
    if (p.kind != Pattern::Kind::kBitPlane) continue;
    absl::StatusOr<cv::Mat> image = Render(p, size);
    ASSERT_TRUE(image.ok());
    absl::StatusOr<cv::Mat> inverse =
        Render({p.kind, p.axis, p.bit, !p.inverse}, size);
    ASSERT_TRUE(inverse.ok());
    EXPECT_EQ(cv::countNonZero(*image + *inverse != 255), 0);
    if (p.inverse) continue;
    cv::Mat& target = p.axis == Axis::kColumns ? column_gray : row_gray;
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        target.at<int>(y, x) =
            (target.at<int>(y, x) << 1) | (image->at<uchar>(y, x) ? 1 : 0);
      }
    }
  }
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      ASSERT_EQ(FromGray(column_gray.at<int>(y, x)), x);
      ASSERT_EQ(FromGray(row_gray.at<int>(y, x)), y);
    }
  }
}

TEST(GrayCodeTest, BadBitIsRejected) {
  EXPECT_EQ(Render({.bit = 10}, {1024, 768}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Render({.bit = -1}, {1024, 768}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(Render({}, {0, 768}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace hdrstereo::structured_light
