// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/cron.h"

#include <array>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::jobs {
namespace {

struct FieldSpec {
  const char* name;
  int min;
  int max;
  const char* const* names;  // names[i] stands for min + i; may be null
  int name_count;
};

constexpr const char* kMonthNames[] = {"JAN", "FEB", "MAR", "APR",
                                       "MAY", "JUN", "JUL", "AUG",
                                       "SEP", "OCT", "NOV", "DEC"};
constexpr const char* kWeekdayNames[] = {"SUN", "MON", "TUE", "WED",
                                         "THU", "FRI", "SAT"};

constexpr std::array<FieldSpec, 5> kFields = {{
    {"minute", 0, 59, nullptr, 0},
    {"hour", 0, 23, nullptr, 0},
    {"day-of-month", 1, 31, nullptr, 0},
    {"month", 1, 12, kMonthNames, 12},
    {"day-of-week", 0, 7, kWeekdayNames, 7},
}};

absl::Status Bad(const FieldSpec& field, absl::string_view token,
                 absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat(
      "cron ", field.name, " field: ", QuoteInput(token), " ", why));
}

absl::StatusOr<int> ParseValue(const FieldSpec& field, absl::string_view text,
                               absl::string_view token) {
  int value = 0;
  if (absl::SimpleAtoi(text, &value)) {
    if (value < field.min || value > field.max) {
      return Bad(field, token,
                 absl::StrCat("is out of range ", field.min, "-", field.max));
    }
    return value;
  }
  const std::string upper = absl::AsciiStrToUpper(text);
  for (int i = 0; i < field.name_count; ++i) {
    if (upper == field.names[i]) return field.min + i;
  }
  return Bad(field, token,
             field.names != nullptr
                 ? absl::StrCat("is not a number ", field.min, "-", field.max,
                                " or a name like ", field.names[0])
                 : absl::StrCat("is not a number ", field.min, "-", field.max));
}

// Sets the bits of `field`'s values in `bits` (indexed by value).
absl::Status ParseField(const FieldSpec& field, absl::string_view text,
                        std::vector<bool>& bits) {
  bits.assign(field.max + 1, false);
  if (text.empty()) return Bad(field, text, "is empty");
  for (absl::string_view item : absl::StrSplit(text, ',')) {
    if (item.empty()) return Bad(field, text, "has an empty list item");
    absl::string_view range = item;
    int step = 1;
    if (size_t slash = item.find('/'); slash != absl::string_view::npos) {
      range = item.substr(0, slash);
      if (!absl::SimpleAtoi(item.substr(slash + 1), &step) || step < 1 ||
          step > field.max) {
        return Bad(
            field, item,
            absl::StrCat("has a step that is not a number 1-", field.max));
      }
    }
    int low = 0;
    int high = 0;
    if (range == "*") {
      low = field.min;
      high = field.max;
    } else if (size_t dash = range.find('-'); dash != absl::string_view::npos) {
      ASSIGN_OR_RETURN(int a, ParseValue(field, range.substr(0, dash), item));
      ASSIGN_OR_RETURN(int b, ParseValue(field, range.substr(dash + 1), item));
      low = a;
      high = b;
      if (low > high) {
        return Bad(field, item, "is a range whose start is after its end");
      }
    } else {
      ASSIGN_OR_RETURN(int a, ParseValue(field, range, item));
      low = a;
      // "a/n" means a-max/n; a plain value is just itself.
      high = range.size() < item.size() ? field.max : low;
    }
    for (int v = low; v <= high; v += step) bits[v] = true;
  }
  return absl::OkStatus();
}

absl::string_view ExpandMacro(absl::string_view expression) {
  const std::string lower = absl::AsciiStrToLower(expression);
  if (lower == "@yearly" || lower == "@annually") return "0 0 1 1 *";
  if (lower == "@monthly") return "0 0 1 * *";
  if (lower == "@weekly") return "0 0 * * 0";
  if (lower == "@daily" || lower == "@midnight") return "0 0 * * *";
  if (lower == "@hourly") return "0 * * * *";
  return expression;
}

int CronWeekday(absl::CivilDay day) {
  switch (absl::GetWeekday(day)) {
    case absl::Weekday::sunday:
      return 0;
    case absl::Weekday::monday:
      return 1;
    case absl::Weekday::tuesday:
      return 2;
    case absl::Weekday::wednesday:
      return 3;
    case absl::Weekday::thursday:
      return 4;
    case absl::Weekday::friday:
      return 5;
    case absl::Weekday::saturday:
      return 6;
  }
  return 0;
}

}  // namespace

absl::StatusOr<absl::TimeZone> LoadZone(absl::string_view name) {
  absl::TimeZone zone = absl::UTCTimeZone();
  if (name.empty()) return zone;
  if (!absl::LoadTimeZone(std::string(name), &zone)) {
    return absl::InvalidArgumentError(
        absl::StrCat("time zone ", QuoteInput(name),
                     " is not a known IANA zone (e.g. Europe/Berlin, UTC)"));
  }
  return zone;
}

absl::StatusOr<CronSchedule> CronSchedule::Parse(absl::string_view expression,
                                                 absl::TimeZone zone) {
  if (expression.size() > kMaxExpressionBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("cron ", QuoteInput(expression), " is ", expression.size(),
                     " bytes long; the most is ", kMaxExpressionBytes));
  }
  const absl::string_view expanded =
      ExpandMacro(absl::StripAsciiWhitespace(expression));
  if (!expanded.empty() && expanded[0] == '@') {
    return absl::InvalidArgumentError(absl::StrCat(
        "cron ", QuoteInput(expanded),
        " is not a known macro (@yearly, @monthly, @weekly, @daily, "
        "@hourly)"));
  }
  std::vector<absl::string_view> fields =
      absl::StrSplit(expanded, absl::ByAnyChar(" \t"), absl::SkipEmpty());
  if (fields.size() != 5) {
    return absl::InvalidArgumentError(absl::StrCat(
        "cron ", QuoteInput(expression), " has ", fields.size(),
        " fields; it needs 5: minute hour day-of-month month day-of-week"));
  }
  CronSchedule cron;
  cron.expression_ = std::string(absl::StripAsciiWhitespace(expression));
  cron.zone_ = zone;
  std::array<std::vector<bool>, 5> bits;
  for (size_t i = 0; i < 5; ++i) {
    RETURN_IF_ERROR(ParseField(kFields[i], fields[i], bits[i]));
  }
  for (int v = 0; v < 60; ++v) cron.minutes_[v] = bits[0][v];
  for (int v = 0; v < 24; ++v) cron.hours_[v] = bits[1][v];
  for (int v = 1; v <= 31; ++v) cron.days_[v] = bits[2][v];
  for (int v = 1; v <= 12; ++v) cron.months_[v] = bits[3][v];
  for (int v = 0; v <= 6; ++v) cron.weekdays_[v] = bits[4][v];
  if (bits[4][7]) cron.weekdays_[0] = true;
  cron.day_star_ = fields[2][0] == '*';
  cron.weekday_star_ = fields[4][0] == '*';
  if (!cron.NextAfter(absl::UnixEpoch()).has_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat("cron ", QuoteInput(expression),
                     " is never due: day-of-month ", QuoteInput(fields[2]),
                     " does not occur in month ", QuoteInput(fields[3])));
  }
  return cron;
}

bool CronSchedule::DayMatches(absl::CivilDay day) const {
  if (!months_[day.month()]) return false;
  const bool dom = days_[day.day()];
  const bool dow = weekdays_[CronWeekday(day)];
  if (day_star_ && weekday_star_) return true;
  if (day_star_) return dow;
  if (weekday_star_) return dom;
  return dom || dow;  // both restricted: either
}

std::optional<absl::Time> CronSchedule::NextAfter(absl::Time t) const {
  if (t == absl::InfiniteFuture() || t == absl::InfinitePast()) {
    return std::nullopt;
  }
  // Civil time is monotonic in absolute time under the DST rule above, so
  // the first matching civil minute whose instant is after `t` is the
  // answer. Start a day early: t may fall in a repeated hour.
  const absl::CivilDay first = absl::CivilDay(absl::ToCivilDay(t, zone_)) - 1;
  const absl::CivilDay last = first + 366 * kSearchYears + 2;
  for (absl::CivilDay day = first; day <= last; ++day) {
    if (!DayMatches(day)) continue;
    for (int h = 0; h < 24; ++h) {
      if (!hours_[h]) continue;
      for (int m = 0; m < 60; ++m) {
        if (!minutes_[m]) continue;
        const absl::TimeZone::TimeInfo info = zone_.At(
            absl::CivilSecond(day.year(), day.month(), day.day(), h, m, 0));
        absl::Time due = info.pre;
        if (info.kind == absl::TimeZone::TimeInfo::SKIPPED) due = info.trans;
        // REPEATED: `pre` (the earlier offset) is the first occurrence.
        if (due > t) return due;
      }
    }
  }
  return std::nullopt;
}

}  // namespace hdrstereo::jobs
