// SPDX-License-Identifier: GPL-3.0-or-later
//
// What the metrics endpoint reads, on a real SQLite store: job events
// counted by their kind (every kind of a family present, 0 included), the
// time of device calls by device and of computed processing steps by step;
// event kinds round-trip through the store and through a status, and a
// kind the binary does not know is refused, not counted as another.
#include "daemon/store/metrics_repository.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "daemon/store/database.h"
#include "daemon/store/device_time_repository.h"
#include "daemon/store/event_kind.h"
#include "daemon/store/job_repository.h"
#include "tests/support/status_matchers.h"
#include "tests/support/store_fixture.h"

namespace hdrstereo::store {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

class MetricsRepositoryTest : public testing::StoreTest {
 protected:
  int64_t Count(const std::string& sql) {
    Database& db = store_->db();
    absl::MutexLock lock(&db.mutex());
    absl::StatusOr<Statement> stmt = db.Prepare(sql);
    EXPECT_OK(stmt.status());
    if (!stmt.ok()) return -1;
    absl::StatusOr<bool> row = stmt->Step();
    EXPECT_TRUE(row.ok() && *row) << sql;
    return stmt->ColumnInt(0);
  }
};

TEST(EventKindTest, EveryKindRoundTripsThroughItsNameAndAStatus) {
  std::set<std::string> names;
  for (EventFamily family :
       {EventFamily::kNone, EventFamily::kVerificationFailure,
        EventFamily::kDeviceError, EventFamily::kStepComputed}) {
    for (EventKind kind : KindsOf(family)) {
      SCOPED_TRACE(EventKindName(kind));
      EXPECT_EQ(FamilyOf(kind), family);
      EXPECT_TRUE(names.insert(EventKindName(kind)).second) << "name twice";
      ASSERT_OK_AND_ASSIGN(EventKind parsed,
                           ParseEventKind(EventKindName(kind)));
      EXPECT_EQ(parsed, kind);
      EXPECT_EQ(DeviceOf(kind).has_value(),
                family == EventFamily::kDeviceError);
      EXPECT_EQ(EventKindOf(WithEventKind(absl::InternalError("x"), kind)),
                kind);
    }
  }
  EXPECT_EQ(names.size(), static_cast<size_t>(EventKind::kStepComputed) + 1);
  EXPECT_EQ(DeviceOf(EventKind::kStageStalled), Device::kStage);
  EXPECT_STREQ(LabelOf(EventKind::kStageStalled), "stalled");
  EXPECT_STREQ(LabelOf(EventKind::kPreviousFile), "previous_file");
  EXPECT_THAT(ParseEventKind("exposure"),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("unknown job event kind \"exposure\"")));
  // OK stays OK, and an error nobody marked has no kind.
  EXPECT_OK(WithEventKind(absl::OkStatus(), EventKind::kCorrupt));
  EXPECT_EQ(EventKindOf(absl::DataLossError("x")), EventKind::kNone);
  for (Device device : kAllDevices) {
    ASSERT_OK_AND_ASSIGN(Device parsed, ParseDevice(DeviceName(device)));
    EXPECT_EQ(parsed, device);
  }
  EXPECT_THAT(ParseDevice("lamp"), StatusIs(absl::StatusCode::kDataLoss,
                                            HasSubstr("unknown device")));
}

TEST_F(MetricsRepositoryTest, EventsAreCountedByKindWithEveryKindPresent) {
  ASSERT_OK(Session("lab").status());
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab"));
  JobRepository jobs(*store_);
  for (EventKind kind :
       {EventKind::kPreviousFile, EventKind::kPreviousFile,
        EventKind::kWrongExposure, EventKind::kCameraDisconnected,
        EventKind::kStageStalled}) {
    ASSERT_OK(jobs.AddEvent(job.id, EventLevel::kWarning, "w", EventTag(kind))
                  .status());
  }
  ASSERT_OK(jobs.AddEvent(job.id, EventLevel::kInfo, "not counted").status());
  ASSERT_OK(jobs.SetState(job.id, JobState::kFailed, "failed: timed out",
                          "timed out", EventTag(EventKind::kCameraTimeout))
                .status());

  ASSERT_OK_AND_ASSIGN(const StoreTotals totals,
                       MetricsRepository(*store_).Read());
  std::map<EventKind, int64_t> expected;
  for (EventFamily family :
       {EventFamily::kVerificationFailure, EventFamily::kDeviceError}) {
    for (EventKind kind : KindsOf(family)) expected[kind] = 0;
  }
  expected[EventKind::kPreviousFile] = 2;
  expected[EventKind::kWrongExposure] = 1;
  expected[EventKind::kCameraDisconnected] = 1;
  expected[EventKind::kStageStalled] = 1;
  expected[EventKind::kCameraTimeout] = 1;
  EXPECT_EQ(totals.events_by_kind, expected);
  // The same as a plain SQL count of the stored names.
  EXPECT_EQ(Count("SELECT count(*) FROM job_events WHERE kind = "
                  "'previous_file'"),
            2);
  EXPECT_EQ(Count("SELECT count(*) FROM job_events WHERE kind = "
                  "'camera_timeout' AND state = 'failed'"),
            1);
  EXPECT_EQ(Count("SELECT count(*) FROM job_events WHERE kind = ''"), 2);

  // The events read back with their tags.
  ASSERT_OK_AND_ASSIGN(std::vector<JobEventRecord> events,
                       jobs.Events(job.id, 0));
  ASSERT_EQ(events.size(), 8u);  // queued + 5 + 1 + failed
  EXPECT_EQ(events[1].tag.kind, EventKind::kPreviousFile);
  EXPECT_EQ(events[6].tag.kind, EventKind::kNone);
  EXPECT_EQ(events[7].tag.kind, EventKind::kCameraTimeout);
  EXPECT_EQ(events[7].state, JobState::kFailed);
}

TEST_F(MetricsRepositoryTest, DeviceTimeByDeviceAndStepTimeByStep) {
  ASSERT_OK(Session("lab").status());
  ASSERT_OK_AND_ASSIGN(const JobRecord capture, Job("lab"));
  ASSERT_OK_AND_ASSIGN(const JobRecord processing,
                       Job("lab", JobKind::kProcessing));
  ASSERT_OK(DeviceTimeRepository(*store_).Record(
      capture.id,
      {{.device = Device::kCamera, .seconds = 0.5, .time_ms = 1},
       {.device = Device::kStage, .seconds = 2, .time_ms = 2},
       {.device = Device::kCamera, .seconds = 0.25, .time_ms = 3}}));
  ASSERT_OK(DeviceTimeRepository(*store_).Record(capture.id, {}));
  JobRepository jobs(*store_);
  for (const auto& [step, seconds] :
       std::vector<std::pair<std::string, double>>{
           {"hdr", 1.5}, {"stereo", 7}, {"hdr", 0.5}}) {
    ASSERT_OK(jobs.AddEvent(processing.id, EventLevel::kInfo, step,
                            EventTag(EventKind::kStepComputed, step, seconds))
                  .status());
  }

  ASSERT_OK_AND_ASSIGN(const StoreTotals totals,
                       MetricsRepository(*store_).Read());
  ASSERT_EQ(totals.device_seconds.size(), 3u);  // the projector's is empty
  EXPECT_THAT(totals.device_seconds.at(Device::kCamera),
              ElementsAre(0.5, 0.25));
  EXPECT_THAT(totals.device_seconds.at(Device::kStage), ElementsAre(2));
  EXPECT_THAT(totals.device_seconds.at(Device::kProjector), IsEmpty());
  ASSERT_EQ(totals.step_seconds.size(), 2u);
  EXPECT_THAT(totals.step_seconds.at("hdr"), ElementsAre(1.5, 0.5));
  EXPECT_THAT(totals.step_seconds.at("stereo"), ElementsAre(7));
  // A computed step is not a verification failure or a device error.
  for (const auto& [kind, count] : totals.events_by_kind) {
    EXPECT_EQ(count, 0) << EventKindName(kind);
  }
  ASSERT_OK_AND_ASSIGN(std::vector<JobEventRecord> events,
                       jobs.Events(processing.id, 1));
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].tag.subject, "hdr");
  EXPECT_EQ(events[0].tag.seconds, 1.5);
}

TEST_F(MetricsRepositoryTest, AKindThisBinaryDoesNotKnowIsRefused) {
  ASSERT_OK(Session("lab").status());
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab"));
  {
    Transaction tx(store_->db());
    ASSERT_OK(tx.status());
    ASSERT_OK(
        store_->db().Exec("UPDATE job_events SET kind = 'camera_on_fire'"));
    ASSERT_OK(tx.Commit());
  }
  EXPECT_THAT(MetricsRepository(*store_).Read(),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("unknown job event kind \"camera_on_fire\"")));
  EXPECT_THAT(
      JobRepository(*store_).Events(job.id, 0),
      StatusIs(absl::StatusCode::kDataLoss, HasSubstr("\"camera_on_fire\"")));
}

}  // namespace
}  // namespace hdrstereo::store
