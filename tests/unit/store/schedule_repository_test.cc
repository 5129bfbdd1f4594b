// SPDX-License-Identifier: GPL-3.0-or-later
//
// ScheduleRepository on a real SQLite store: schedules created, listed,
// enabled and deleted (with their runs); runs recorded once per due time,
// updated and read newest first.
#include "daemon/store/schedule_repository.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tests/support/status_matchers.h"
#include "tests/support/store_fixture.h"

namespace hdrstereo::store {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

ScheduleRecord Nightly(const std::string& name) {
  ScheduleRecord s;
  s.name = name;
  s.cron = "0 2 * * *";
  s.time_zone = "Europe/Berlin";
  s.plan = "serialized plan";
  s.missed_run_policy = MissedRunPolicy::kSkip;
  s.created_by = "alice";
  return s;
}

class ScheduleRepositoryTest : public testing::StoreTest {};

TEST_F(ScheduleRepositoryTest, CreateGetListAndBadNames) {
  ScheduleRepository schedules(*store_);
  ASSERT_OK_AND_ASSIGN(const ScheduleRecord b,
                       schedules.Create(Nightly("b-nightly"), 1000));
  EXPECT_EQ(b.create_time_ms, 1000);
  EXPECT_EQ(b.enable_time_ms, 1000);
  EXPECT_EQ(b.enabled_by, "alice");  // the creator, until enabled again
  EXPECT_TRUE(b.enabled);
  ASSERT_OK(schedules.Create(Nightly("a-nightly"), 2000).status());
  ASSERT_OK_AND_ASSIGN(const ScheduleRecord got, schedules.Get("b-nightly"));
  EXPECT_EQ(got.cron, "0 2 * * *");
  EXPECT_EQ(got.time_zone, "Europe/Berlin");
  EXPECT_EQ(got.plan, "serialized plan");
  EXPECT_EQ(got.missed_run_policy, MissedRunPolicy::kSkip);
  EXPECT_FALSE(got.last_due_time_ms.has_value());
  ASSERT_OK_AND_ASSIGN(const std::vector<ScheduleRecord> listed,
                       schedules.List("", 10));
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].name, "a-nightly");
  EXPECT_EQ(schedules.List("a-nightly", 10)->size(), 1u);
  EXPECT_THAT(schedules.Create(Nightly("b-nightly"), 3000),
              StatusIs(absl::StatusCode::kAlreadyExists,
                       HasSubstr("\"b-nightly\" already exists")));
  EXPECT_THAT(
      schedules.Create(Nightly("no spaces"), 3000),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("schedule name")));
  EXPECT_THAT(schedules.Get("c"),
              StatusIs(absl::StatusCode::kNotFound,
                       HasSubstr("no schedule named \"c\"")));
}

TEST_F(ScheduleRepositoryTest, EnablingAgainMovesTheEnableTime) {
  ScheduleRepository schedules(*store_);
  ASSERT_OK(schedules.Create(Nightly("n"), 1000).status());
  ASSERT_OK_AND_ASSIGN(ScheduleRecord s,
                       schedules.SetEnabled("n", false, 5, "bob"));
  EXPECT_FALSE(s.enabled);
  EXPECT_EQ(s.enable_time_ms, 1000);
  ASSERT_OK_AND_ASSIGN(s, schedules.SetEnabled("n", true, 9000, "bob"));
  EXPECT_TRUE(s.enabled);
  EXPECT_EQ(s.enable_time_ms, 9000);
  EXPECT_EQ(s.enabled_by, "bob");
  EXPECT_EQ(s.created_by, "alice");
  // Enabling an enabled schedule changes nothing.
  ASSERT_OK_AND_ASSIGN(s, schedules.SetEnabled("n", true, 12000, "carol"));
  EXPECT_EQ(s.enable_time_ms, 9000);
  EXPECT_EQ(s.enabled_by, "bob");
  EXPECT_THAT(schedules.SetEnabled("x", true, 1, "bob"),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("\"x\"")));
}

TEST_F(ScheduleRepositoryTest, RunsOncePerDueTimeNewestFirstAndDeletedWith) {
  ScheduleRepository schedules(*store_);
  ASSERT_OK_AND_ASSIGN(const ScheduleRecord n,
                       schedules.Create(Nightly("n"), 1000));
  ScheduleRunRecord run;
  run.schedule_id = n.id;
  run.session = "n-1";
  for (int64_t due : {2000, 4000, 3000}) {
    run.due_time_ms = due;
    ASSERT_OK(schedules.AddRun(run).status());
  }
  run.due_time_ms = 4000;
  EXPECT_THAT(schedules.AddRun(run),
              StatusIs(absl::StatusCode::kAlreadyExists));
  ASSERT_OK_AND_ASSIGN(std::vector<ScheduleRunRecord> runs,
                       schedules.Runs("n", 0, 10));
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runs[0].due_time_ms, 4000);
  EXPECT_EQ(runs[2].due_time_ms, 2000);
  EXPECT_EQ(schedules.Get("n")->last_due_time_ms, 4000);
  EXPECT_EQ(schedules.Runs("n", 4000, 10)->front().due_time_ms, 3000);
  EXPECT_EQ(schedules.RunningRuns()->size(), 3u);

  ScheduleRunRecord done = runs[0];
  done.outcome = RunOutcome::kSucceeded;
  done.job_ids = {7, 8};
  done.end_time_ms = 5000;
  done.reason = "captured";
  ASSERT_OK(schedules.UpdateRun(done));
  ASSERT_OK_AND_ASSIGN(runs, schedules.Runs("n", 0, 1));
  EXPECT_EQ(runs[0].outcome, RunOutcome::kSucceeded);
  EXPECT_EQ(runs[0].job_ids, (std::vector<int64_t>{7, 8}));
  EXPECT_EQ(runs[0].end_time_ms, 5000);
  EXPECT_EQ(runs[0].reason, "captured");
  EXPECT_EQ(schedules.RunningRuns()->size(), 2u);

  ASSERT_OK(schedules.Delete("n"));
  EXPECT_THAT(schedules.Runs("n", 0, 10),
              StatusIs(absl::StatusCode::kNotFound));
  EXPECT_TRUE(schedules.RunningRuns()->empty());
  EXPECT_THAT(schedules.Delete("n"), StatusIs(absl::StatusCode::kNotFound));
}

}  // namespace
}  // namespace hdrstereo::store
