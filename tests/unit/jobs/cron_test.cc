// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/cron.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::jobs {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

absl::TimeZone Zone(const std::string& name) {
  absl::StatusOr<absl::TimeZone> zone = LoadZone(name);
  EXPECT_TRUE(zone.ok()) << zone.status();
  return zone.value_or(absl::UTCTimeZone());
}

absl::Time Utc(const std::string& text) {
  absl::Time t;
  std::string error;
  EXPECT_TRUE(absl::ParseTime("%Y-%m-%d %H:%M", text, &t, &error)) << error;
  return t;
}

std::string Fmt(absl::Time t) {
  return absl::FormatTime("%Y-%m-%d %H:%M", t, absl::UTCTimeZone());
}

struct Case {
  const char* cron;
  const char* zone;
  const char* after;              // UTC
  std::vector<const char*> next;  // UTC, successive NextAfter
};

TEST(CronTest, NextTimesTable) {
  const std::vector<Case> cases = {
      // Nightly at 02:00 UTC.
      {"0 2 * * *",
       "UTC",
       "2026-11-23 19:48",
       {"2026-11-24 02:00", "2026-11-25 02:00"}},
      // Steps and lists.
      {"*/20 9,17 * * *",
       "UTC",
       "2026-11-23 09:30",
       {"2026-11-23 09:40", "2026-11-23 17:00", "2026-11-23 17:20"}},
      {"5/30 * * * *",
       "",
       "2026-01-01 00:00",
       {"2026-01-01 00:05", "2026-01-01 00:35", "2026-01-01 01:05"}},
      // Weekday names and ranges: Mon-Fri 06:15 (2026-11-27 is a Friday).
      {"15 6 * * MON-FRI",
       "UTC",
       "2026-11-27 07:00",
       {"2026-11-30 06:15", "2026-12-01 06:15"}},
      // 7 is Sunday too (2026-11-29 is a Sunday).
      {"0 0 * * 7", "UTC", "2026-11-23 00:00", {"2026-11-29 00:00"}},
      // Feb 29 only in leap years.
      {"0 12 29 FEB *",
       "UTC",
       "2026-01-01 00:00",
       {"2028-02-29 12:00", "2032-02-29 12:00"}},
      // Last-day ranges: 28-31 in February and April.
      {"0 0 28-31 * *",
       "UTC",
       "2027-02-27 00:00",
       {"2027-02-28 00:00", "2027-03-28 00:00", "2027-03-29 00:00"}},
      {"0 0 31 * *",
       "UTC",
       "2026-04-01 00:00",
       {"2026-05-31 00:00", "2026-07-31 00:00", "2026-08-31 00:00"}},
      // Both day fields restricted: either matches (1st or a Monday).
      {"0 0 1 * MON",
       "UTC",
       "2026-11-28 00:00",
       {"2026-11-30 00:00", "2026-12-01 00:00", "2026-12-07 00:00"}},
      // Day-of-month restricted, weekday "*": only the day.
      {"0 0 13 * *", "UTC", "2026-11-01 00:00", {"2026-11-13 00:00"}},
      // Macros and months by name.
      {"@daily", "UTC", "2026-11-23 19:48", {"2026-11-24 00:00"}},
      {"0 0 1 jan-mar/2 *",
       "UTC",
       "2026-01-01 00:00",
       {"2026-03-01 00:00", "2027-01-01 00:00"}},
      // A zone: 02:00 Berlin is 01:00 UTC in winter, 00:00 UTC in summer.
      {"0 2 * * *", "Europe/Berlin", "2026-11-23 19:48", {"2026-11-24 01:00"}},
      {"0 2 * * *", "Europe/Berlin", "2026-07-01 12:00", {"2026-07-02 00:00"}},
      // Spring forward, Berlin 2026-03-29: 02:00-02:59 does not exist; a
      // 02:30 schedule runs once, at the transition (03:00 CEST = 01:00 UTC).
      {"30 2 * * *",
       "Europe/Berlin",
       "2026-03-28 12:00",
       {"2026-03-29 01:00", "2026-03-30 00:30"}},
      // Fall back, Berlin 2026-10-25: 02:30 happens twice; it runs once, at
      // the first (02:30 CEST = 00:30 UTC).
      {"30 2 * * *",
       "Europe/Berlin",
       "2026-10-24 12:00",
       {"2026-10-25 00:30", "2026-10-26 01:30"}},
      // New York, spring forward 2026-03-08 02:00 EST -> 03:00 EDT.
      {"30 2 * * *",
       "America/New_York",
       "2026-03-07 12:00",
       {"2026-03-08 07:00", "2026-03-09 06:30"}},
      // New York, fall back 2026-11-01: 01:30 runs once, EDT (05:30 UTC).
      {"30 1 * * *",
       "America/New_York",
       "2026-10-31 12:00",
       {"2026-11-01 05:30", "2026-11-02 06:30"}},
  };
  for (const Case& c : cases) {
    absl::StatusOr<CronSchedule> cron =
        CronSchedule::Parse(c.cron, Zone(c.zone));
    ASSERT_TRUE(cron.ok()) << c.cron << ": " << cron.status();
    absl::Time t = Utc(c.after);
    for (const char* expected : c.next) {
      std::optional<absl::Time> next = cron->NextAfter(t);
      ASSERT_TRUE(next.has_value()) << c.cron;
      EXPECT_EQ(Fmt(*next), expected)
          << c.cron << " in " << c.zone << " after " << Fmt(t);
      t = *next;
    }
  }
}

TEST(CronTest, EveryMinuteInTheGapRunsOnceAtTheTransition) {
  absl::StatusOr<CronSchedule> cron =
      CronSchedule::Parse("*/15 2 * * *", Zone("Europe/Berlin"));
  ASSERT_TRUE(cron.ok());
  std::optional<absl::Time> a = cron->NextAfter(Utc("2026-03-28 12:00"));
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(Fmt(*a), "2026-03-29 01:00");
  std::optional<absl::Time> b = cron->NextAfter(*a);
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(Fmt(*b), "2026-03-30 00:00");
}

TEST(CronTest, HourlyDuringFallBackRunsEachCivilHourOnce) {
  // 00:00 .. 04:00 local on the fall-back day: 02:00 only once.
  absl::StatusOr<CronSchedule> cron =
      CronSchedule::Parse("0 * * * *", Zone("Europe/Berlin"));
  ASSERT_TRUE(cron.ok());
  std::vector<std::string> got;
  absl::Time t = Utc("2026-10-24 21:30");  // 23:30 CEST
  for (int i = 0; i < 5; ++i) {
    t = *cron->NextAfter(t);
    got.push_back(Fmt(t));
  }
  EXPECT_THAT(got,
              ::testing::ElementsAre("2026-10-24 22:00",  // 00:00 CEST
                                     "2026-10-24 23:00",  // 01:00 CEST
                                     "2026-10-25 00:00",  // 02:00 CEST (first)
                                     "2026-10-25 02:00",  // 03:00 CET
                                     "2026-10-25 03:00"));  // 04:00 CET
}

TEST(CronTest, ErrorsNameTheOffendingToken) {
  struct Bad {
    const char* cron;
    const char* says;
  };
  const std::vector<Bad> bad = {
      {"0 2 * *", "has 4 fields"},
      {"60 2 * * *", "minute field: \"60\" is out of range 0-59"},
      {"0 24 * * *", "hour field: \"24\""},
      {"0 2 0 * *", "day-of-month field: \"0\""},
      {"0 2 * FOO *", "month field: \"FOO\""},
      {"0 2 * * MON-XYZ", "day-of-week field: \"MON-XYZ\""},
      {"0 2 * * 5-1", "\"5-1\" is a range whose start is after its end"},
      {"*/0 2 * * *", "\"*/0\" has a step"},
      {"0 2 1,,2 * *", "empty list item"},
      {"0 0 30 2 *", "never due"},
      {"0 0 31 4,6 *", "never due"},
      {"@sometimes", "not a known macro"},
  };
  for (const Bad& b : bad) {
    absl::StatusOr<CronSchedule> cron =
        CronSchedule::Parse(b.cron, absl::UTCTimeZone());
    ASSERT_FALSE(cron.ok()) << b.cron;
    EXPECT_EQ(cron.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(cron.status().message()), HasSubstr(b.says))
        << b.cron;
  }
}

// Hostile expressions: a length limit, numbers and steps that overflow or
// exceed their field, long lists; every one ends and says what is wrong, with
// what it quotes bounded.
TEST(CronTest, HostileExpressionsAreBoundedAndRefusedByName) {
  // Every minute listed, and again: a list up to the limit is read.
  std::string list = "0";
  for (int m = 1; m < 60; ++m) absl::StrAppend(&list, ",", m);
  while (list.size() + 3 + 8 <= CronSchedule::kMaxExpressionBytes) {
    absl::StrAppend(&list, ",", list.size() % 60);
  }
  ASSERT_OK_AND_ASSIGN(
      CronSchedule every,
      CronSchedule::Parse(list + " * * * *", absl::UTCTimeZone()));
  EXPECT_EQ(Fmt(*every.NextAfter(Utc("2026-03-01 10:00"))), "2026-03-01 10:01");

  const std::string too_long(CronSchedule::kMaxExpressionBytes + 1, '*');
  absl::StatusOr<CronSchedule> refused =
      CronSchedule::Parse(too_long, absl::UTCTimeZone());
  EXPECT_THAT(refused.status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("\"... (1025 bytes) is 1025 bytes long; the "
                                 "most is 1024")));
  EXPECT_LT(refused.status().message().size(), 200u);

  struct Bad {
    std::string cron;
    std::string says;
  };
  for (const Bad& b : std::vector<Bad>{
           {"*/99999999999 * * * *", "has a step that is not a number 1-59"},
           {"*/60 * * * *", "has a step that is not a number 1-59"},
           {"0-59/-1 * * * *", "has a step"},
           {"99999999999 * * * *", "\"99999999999\" is not a number 0-59"},
           {"0 0 1-99999999999 * *", "is not a number 1-31"},
           {"0 0 * * 2147483647", "is out of range 0-7"},
           {"--1 * * * *", "minute field: \"--1\" is not a number"},
           {std::string("0\0 * * * *", 10), "\"0\\x00\" is not a number"},
           {std::string(200, '1') + " * * * *",
            "\"... (200 bytes) is not a number 0-59"},
       }) {
    absl::StatusOr<CronSchedule> cron =
        CronSchedule::Parse(b.cron, absl::UTCTimeZone());
    EXPECT_THAT(cron.status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(b.says)))
        << b.cron;
    EXPECT_LT(cron.status().message().size(), 300u) << b.cron;
  }
  EXPECT_FALSE(every.NextAfter(absl::InfiniteFuture()).has_value());
  EXPECT_FALSE(every.NextAfter(absl::InfinitePast()).has_value());
}

TEST(CronTest, UnknownZoneIsRefused) {
  absl::StatusOr<absl::TimeZone> zone = LoadZone("Europe/Atlantis");
  ASSERT_FALSE(zone.ok());
  EXPECT_THAT(std::string(zone.status().message()),
              HasSubstr("Europe/Atlantis"));
  EXPECT_TRUE(LoadZone("").ok());
}

}  // namespace
}  // namespace hdrstereo::jobs
