// SPDX-License-Identifier: GPL-3.0-or-later
//
// Standard 5-field cron expressions (minute hour day-of-month month
// day-of-week) evaluated in an IANA time zone.
//
// Fields take `*`, numbers, ranges `a-b`, lists `a,b`, steps `*/n`, `a-b/n`
// and `a/n` (= a-max/n), month names JAN..DEC and weekday names SUN..SAT
// (case-insensitive); weekday 0 and 7 are both Sunday. The macros @yearly,
// @annually, @monthly, @weekly, @daily, @midnight and @hourly are accepted.
// As in Vixie cron, when both day-of-month and day-of-week are restricted
// (neither starts with `*`) a day matches if EITHER matches.
//
// Daylight-saving rule: due times are civil times in the zone, and every
// civil time that matches runs exactly once.
//  - Spring forward (a civil time that does not exist, e.g. 02:30 on the
//    last Sunday of March in Europe/Berlin): it runs at the transition
//    instant (03:00 local). Several matching times in the gap collapse into
//    that one run.
//  - Fall back (a civil time that happens twice, e.g. 02:30 on the last
//    Sunday of October): it runs at its first occurrence only (02:30 CEST);
//    the repeated hour does not run again.
#ifndef HDRSTEREO_DAEMON_JOBS_CRON_H_
#define HDRSTEREO_DAEMON_JOBS_CRON_H_

#include <bitset>
#include <cstddef>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

namespace hdrstereo::jobs {

// Loads an IANA zone ("" = UTC); INVALID_ARGUMENT naming an unknown zone.
absl::StatusOr<absl::TimeZone> LoadZone(absl::string_view name);

class CronSchedule {
 public:
  // INVALID_ARGUMENT naming the offending field and token (quoted bounded)
  // for a malformed expression, for one longer than kMaxExpressionBytes, and
  // for one that is never due (e.g. "0 0 30 2 *").
  static absl::StatusOr<CronSchedule> Parse(absl::string_view expression,
                                            absl::TimeZone zone);

  // The first due time strictly after `t`; nullopt when none comes within
  // kSearchYears (only for expressions that are never due) and for an
  // infinite `t`.
  std::optional<absl::Time> NextAfter(absl::Time t) const;

  const std::string& expression() const { return expression_; }
  absl::TimeZone zone() const { return zone_; }

  static constexpr int kSearchYears = 9;  // covers every Feb 29
  // Every value of every field listed one by one ("0,1,...,59 ...") takes
  // under 400 bytes.
  static constexpr size_t kMaxExpressionBytes = 1024;

 private:
  CronSchedule() = default;
  bool DayMatches(absl::CivilDay day) const;

  std::string expression_;
  absl::TimeZone zone_;
  std::bitset<60> minutes_;
  std::bitset<24> hours_;
  std::bitset<32> days_;     // 1..31
  std::bitset<13> months_;   // 1..12
  std::bitset<7> weekdays_;  // 0 = Sunday
  bool day_star_ = false;
  bool weekday_star_ = false;
};

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_CRON_H_
