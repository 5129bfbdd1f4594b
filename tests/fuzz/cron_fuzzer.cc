// SPDX-License-Identifier: GPL-3.0-or-later
// Cron expressions of nightly-acquisition schedules.
#include "absl/time/time.h"
#include "daemon/jobs/cron.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace jobs = hdrstereo::jobs;
  // The first byte picks a zone with daylight saving time or UTC.
  if (size == 0) return 0;
  static const absl::TimeZone kBerlin = *jobs::LoadZone("Europe/Berlin");
  const absl::TimeZone zone = data[0] % 2 == 0 ? absl::UTCTimeZone() : kBerlin;
  absl::StatusOr<jobs::CronSchedule> schedule = jobs::CronSchedule::Parse(
      hdrstereo::fuzz::AsText(data + 1, size - 1), zone);
  if (!schedule.ok()) return 0;
  // A schedule the parser accepts is due at some time, strictly later.
  const absl::Time start = absl::FromUnixSeconds(1'790'000'000);  // 2026
  const std::optional<absl::Time> first = schedule->NextAfter(start);
  FUZZ_CHECK(first.has_value() && *first > start);
  const std::optional<absl::Time> second = schedule->NextAfter(*first);
  FUZZ_CHECK(second.has_value() && *second > *first);
  return 0;
}
