// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo jobs watch`'s progress line: counts outside [0, total] (a
// cluster log's "[7/3]"), a total of 0 and negative counts draw a bar
// within its width instead of throwing std::length_error.
#include "clients/cli/progress_bar.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <string>

namespace hdrstereo::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

const std::string kFull(30, '#');
const std::string kEmpty(30, '-');

TEST(ProgressLineTest, DrawsTheShareDone) {
  const std::string line = ProgressLine(3, 10, 0.5, "stereo: reinhard");
  EXPECT_THAT(line,
              StartsWith("[" + std::string(9, '#') + std::string(21, '-') +
                         "] 3/10  30%  0.50/s "
                         "ETA 0:00:14  stereo: reinhard"));
}

TEST(ProgressLineTest, MoreDoneThanTotalFillsTheBar) {
  std::string line;
  ASSERT_NO_THROW(line = ProgressLine(7, 3, 1.0, "step"));
  // The counts as reported; the bar, share and ETA clamped.
  EXPECT_THAT(line, StartsWith("[" + kFull + "] 7/3 100%  1.00/s ETA 0:00:00"));
  ASSERT_NO_THROW(
      line = ProgressLine(std::numeric_limits<int64_t>::max(), 3, 1.0, "step"));
  EXPECT_THAT(line, StartsWith("[" + kFull + "] 9223372036854775807/3 100%"));
}

TEST(ProgressLineTest, ZeroTotalDrawsAnEmptyBar) {
  std::string line;
  ASSERT_NO_THROW(line = ProgressLine(0, 0, 0.0, "step"));
  EXPECT_THAT(line, StartsWith("[" + kEmpty + "] 0/0   0%  0.00/s ETA --:--"));
  ASSERT_NO_THROW(line = ProgressLine(5, 0, 2.0, "step"));
  EXPECT_THAT(line, StartsWith("[" + kEmpty + "] 5/0   0%"));
}

TEST(ProgressLineTest, NegativeCountsDrawAnEmptyBar) {
  std::string line;
  ASSERT_NO_THROW(line = ProgressLine(-4, 10, -1.0, "step"));
  EXPECT_THAT(line,
              StartsWith("[" + kEmpty + "] -4/10   0% -1.00/s ETA --:--"));
  ASSERT_NO_THROW(line = ProgressLine(2, -3, 1.0, "step"));
  EXPECT_THAT(line, StartsWith("[" + kEmpty + "] 2/-3   0%"));
  ASSERT_NO_THROW(line = ProgressLine(std::numeric_limits<int64_t>::min(),
                                      std::numeric_limits<int64_t>::max(), 1.0,
                                      "step"));
  EXPECT_THAT(line, StartsWith("[" + kEmpty + "] "));
}

TEST(ProgressLineTest, TheStepIsCutAt40Bytes) {
  const std::string line = ProgressLine(1, 2, 0.0, std::string(100, 's'));
  EXPECT_THAT(line, HasSubstr("  " + std::string(40, 's')));
  EXPECT_THAT(line, ::testing::Not(HasSubstr(std::string(41, 's'))));
}

// A step name from the cluster's log reaches the terminal without its
// control characters: an escape sequence, a carriage return that would
// redraw the line, a bell, and bytes beyond ASCII are each '?'.
TEST(ProgressLineTest, TheStepShowsOnlyPrintableAscii) {
  const std::string line =
      ProgressLine(1, 2, 0.0, "st\x1b[2Jep\r\a\x7f caf\xc3\xa9 done");
  EXPECT_THAT(line, HasSubstr("  st?[2Jep??? caf?? done"));
  for (const char c : line) {
    EXPECT_TRUE(c >= ' ' && c <= '~') << static_cast<int>(c);
  }
  // Padded to its 40 bytes.
  EXPECT_EQ(line.size(), ProgressLine(1, 2, 0.0, "").size());
}

TEST(FormatDurationTest, HoursMinutesSecondsOrDashes) {
  EXPECT_EQ(FormatDuration(0), "0:00:00");
  EXPECT_EQ(FormatDuration(3725.4), "1:02:05");
  EXPECT_EQ(FormatDuration(-1), "--:--");
  EXPECT_EQ(FormatDuration(std::numeric_limits<double>::quiet_NaN()), "--:--");
  EXPECT_EQ(FormatDuration(360001), "--:--");
}

}  // namespace
}  // namespace hdrstereo::cli
