// SPDX-License-Identifier: GPL-3.0-or-later
#include "clients/cli/time_args.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/status_matchers.h"

namespace hdrstereo::cli {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

TEST(TimeArgsTest, Durations) {
  EXPECT_EQ(*ParseDurationArg("90s"), absl::Seconds(90));
  EXPECT_EQ(*ParseDurationArg("3600"), absl::Hours(1));
  EXPECT_EQ(*ParseDurationArg("30m"), absl::Minutes(30));
  EXPECT_EQ(*ParseDurationArg("1h30m"), absl::Minutes(90));
  EXPECT_EQ(*ParseDurationArg("7d"), absl::Hours(168));
  EXPECT_EQ(*ParseDurationArg("2w"), absl::Hours(336));
  for (const char* bad : {"", "0", "-5m", "soon", "3x", "d", "inf"}) {
    EXPECT_THAT(ParseDurationArg(bad),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("not a positive duration")))
        << bad;
  }
}

TEST(TimeArgsTest, TimesAbsoluteOrBackFromNow) {
  const absl::TimeZone utc = absl::UTCTimeZone();
  const absl::Time now = absl::FromUnixSeconds(1'800'000'000);
  absl::Time day;
  ASSERT_TRUE(absl::ParseTime("%Y-%m-%d", "2026-11-23", utc, &day, nullptr));
  EXPECT_EQ(*ParseTimeArg("2026-11-23", now, utc), day);
  EXPECT_EQ(*ParseTimeArg("2026-11-23 14:05", now, utc),
            day + absl::Hours(14) + absl::Minutes(5));
  EXPECT_EQ(*ParseTimeArg("2026-11-23T14:05:30", now, utc),
            day + absl::Hours(14) + absl::Minutes(5) + absl::Seconds(30));
  EXPECT_EQ(*ParseTimeArg("2h", now, utc), now - absl::Hours(2));
  EXPECT_THAT(ParseTimeArg("yesterday", now, utc),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("neither a time")));
}

}  // namespace
}  // namespace hdrstereo::cli
