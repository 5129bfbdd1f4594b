// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/base/input_limits.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <string>

namespace hdrstereo {
namespace {

using ::testing::HasSubstr;

TEST(QuoteInputTest, ShortTextIsQuotedWholeAndEscaped) {
  EXPECT_EQ(QuoteInput("ab\n\"c"), "\"ab\\n\\\"c\"");
}

TEST(QuoteInputTest, LongTextKeepsABoundedPrefixAndItsSize) {
  const std::string huge(2'000'000, 'x');
  const std::string quoted = QuoteInput(huge);
  EXPECT_LT(quoted.size(), kMaxQuotedBytes + 40);
  EXPECT_THAT(quoted, HasSubstr("... (2000000 bytes)"));
  EXPECT_EQ(quoted.substr(0, 5), "\"xxxx");
}

TEST(QuoteInputTest, AnotherBoundKeepsThatMany) {
  EXPECT_EQ(QuoteInput("abcdef", 4), "\"abcd\"... (6 bytes)");
  EXPECT_EQ(QuoteInput("abcdef", 6), "\"abcdef\"");
  EXPECT_EQ(QuoteInput(std::string(300, 'x'), 256),
            "\"" + std::string(256, 'x') + "\"... (300 bytes)");
}

TEST(QuoteInputTailTest, ShortTextIsQuotedWholeAndEscaped) {
  EXPECT_EQ(QuoteInputTail("error: \x1b[2J\n", 100), "\"error: \\x1b[2J\\n\"");
  EXPECT_EQ(QuoteInputTail("", 100), "\"\"");
}

TEST(QuoteInputTailTest, LongTextKeepsABoundedTailAndSaysWhatWasLeftOut) {
  const std::string huge = std::string(2'000'000, 'x') + "sbatch: error: ok";
  const std::string quoted = QuoteInputTail(huge, 17);
  EXPECT_EQ(quoted, "(2000000 bytes left out) ...\"sbatch: error: ok\"");
  EXPECT_EQ(QuoteInputTail("abcdef", 0), "(6 bytes left out) ...\"\"");
}

TEST(QuoteInputTailTest, BytesAlreadyDroppedAreCounted) {
  // A reader kept the last 4 bytes of a 1004-byte stream.
  EXPECT_EQ(QuoteInputTail("tail", 100, 1000),
            "(1000 bytes left out) ...\"tail\"");
  EXPECT_EQ(QuoteInputTail("0123456789", 4, 1000),
            "(1006 bytes left out) ...\"6789\"");
}

TEST(CheckRangeTest, NamesTheFieldTheValueAndTheLimits) {
  EXPECT_TRUE(CheckRange("width", 5, 1, 10).ok());
  const absl::Status s = CheckRange("PFM width", -3, 1, 1048576);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "PFM width: -3 is outside [1, 1048576]");
}

TEST(CheckedMultiplyTest, RefusesOverflowAndProductsAboveTheLimit) {
  EXPECT_EQ(*CheckedMultiply("n", 1000, 1000, 1'000'000), 1'000'000u);
  const auto over = CheckedMultiply("n", 1001, 1000, 1'000'000);
  EXPECT_EQ(over.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(over.status().message(),
            "n: 1001 x 1000 is more than the limit of 1000000");
  // 2^32 * 2^32 wraps to 0 in 64 bits: refused, not accepted as 0.
  const auto wraps =
      CheckedMultiply("n", uint64_t{1} << 32, uint64_t{1} << 32, UINT64_MAX);
  EXPECT_EQ(wraps.status().code(), absl::StatusCode::kInvalidArgument);
}

// OPENCV_IO_MAX_IMAGE_* as DecodedImageLimits reads them: a value above
// INT_MAX is INT_MAX for a width or height (cv::Mat's sides are int), and
// anything but a whole number above 0 is the default.
TEST(ImageLimitFromEnvTest, ClampsToTheMaximumAndFallsBackOnNonsense) {
  constexpr int64_t kIntMax = std::numeric_limits<int>::max();
  EXPECT_EQ(ImageLimitFromEnv("4096", 1 << 20, kIntMax), 4096);
  EXPECT_EQ(ImageLimitFromEnv("2147483647", 1 << 20, kIntMax), kIntMax);
  EXPECT_EQ(ImageLimitFromEnv("2147483648", 1 << 20, kIntMax), kIntMax);
  EXPECT_EQ(ImageLimitFromEnv("9223372036854775807", 1 << 20, kIntMax),
            kIntMax);
  for (const char* nonsense : {static_cast<const char*>(nullptr), "", "0", "-5",
                               "12x", "1MB", "99999999999999999999"}) {
    EXPECT_EQ(ImageLimitFromEnv(nonsense, 1 << 20, kIntMax), 1 << 20)
        << (nonsense == nullptr ? "unset" : nonsense);
  }
  EXPECT_EQ(ImageLimitFromEnv("9223372036854775807", int64_t{1} << 30,
                              std::numeric_limits<int64_t>::max()),
            std::numeric_limits<int64_t>::max());
}

// The suite runs with OpenCV's default limits (no OPENCV_IO_MAX_IMAGE_*).
TEST(ImageBytesTest, ChecksEachFieldAgainstOpenCvsLimits) {
  ASSERT_EQ(DecodedImageLimits().max_width, 1 << 20);
  ASSERT_EQ(DecodedImageLimits().max_pixels, 1 << 30);
  EXPECT_EQ(*ImageBytes("PFM", 640, 480, 3, 4), 640u * 480 * 3 * 4);
  EXPECT_EQ(ImageBytes("PFM", 0, 480, 3, 4).status().message(),
            "PFM width: 0 is outside [1, 1048576]");
  EXPECT_EQ(ImageBytes("PFM", 640, 2'000'000, 3, 4).status().message(),
            "PFM height: 2000000 is outside [1, 1048576]");
  // Each side within its limit, the area not: 2^20 x 2^20 > 2^30 pixels.
  EXPECT_THAT(
      std::string(ImageBytes("EXR", int64_t{1} << 20, int64_t{1} << 20, 1, 4)
                      .status()
                      .message()),
      HasSubstr("EXR pixels (width x height): 1048576 x 1048576 is more than "
                "the limit of 1073741824"));
}

}  // namespace
}  // namespace hdrstereo
