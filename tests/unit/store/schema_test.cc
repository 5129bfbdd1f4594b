// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/schema.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <string>

#include "daemon/store/audit_repository.h"
#include "daemon/store/device_time_repository.h"
#include "daemon/store/frame_repository.h"
#include "daemon/store/job_repository.h"
#include "daemon/store/metrics_repository.h"
#include "daemon/store/store.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::store {
namespace {

using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::TempDir;
using ::testing::HasSubstr;
using ::testing::IsSupersetOf;

std::string QueryText(Database& db, const std::string& sql) {
  absl::MutexLock lock(&db.mutex());
  absl::StatusOr<Statement> stmt = db.Prepare(sql);
  EXPECT_TRUE(stmt.ok()) << stmt.status();
  if (!stmt.ok()) return "";
  absl::StatusOr<bool> row = stmt->Step();
  EXPECT_TRUE(row.ok() && *row) << sql;
  return stmt->ColumnText(0);
}

TEST(SchemaTest, FreshDatabaseGetsEveryTableInWalModeWithForeignKeys) {
  TempDir dir;
  absl::StatusOr<std::unique_ptr<Store>> store = Store::Open(dir.path());
  ASSERT_TRUE(store.ok()) << store.status();
  Database& db = (*store)->db();
  EXPECT_EQ((*store)->schema_version(), LatestSchemaVersion());
  EXPECT_EQ(QueryText(db, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(QueryText(db, "PRAGMA foreign_keys"), "1");

  std::set<std::string> tables;
  {
    absl::MutexLock lock(&db.mutex());
    absl::StatusOr<Statement> stmt =
        db.Prepare("SELECT name FROM sqlite_master WHERE type = 'table'");
    ASSERT_TRUE(stmt.ok());
    while (*stmt->Step()) tables.insert(stmt->ColumnText(0));
  }
  EXPECT_THAT(tables, IsSupersetOf({"schema_version", "rigs", "sessions",
                                    "captures", "frames", "artifacts", "jobs",
                                    "job_events", "metrics", "schedules"}));
}

TEST(SchemaTest, ReopeningDoesNotMigrateAgain) {
  TempDir dir;
  ASSERT_TRUE(Store::Open(dir.path()).ok());
  absl::StatusOr<std::unique_ptr<Store>> again = Store::Open(dir.path());
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(QueryText((*again)->db(), "SELECT count(*) FROM schema_version"),
            std::to_string(LatestSchemaVersion()));
}

TEST(SchemaTest, NewerDatabaseIsRefusedAndLeftUntouched) {
  TempDir dir;
  {
    absl::StatusOr<std::unique_ptr<Store>> store = Store::Open(dir.path());
    ASSERT_TRUE(store.ok());
    Database& db = (*store)->db();
    absl::MutexLock lock(&db.mutex());
    ASSERT_TRUE(db.Exec("INSERT INTO schema_version VALUES (999, 0); "
                        "PRAGMA wal_checkpoint(TRUNCATE);")
                    .ok());
  }
  const std::filesystem::path db_path = dir / "hdrstereo.db";
  const std::string before = ReadFileOrDie(db_path);

  absl::StatusOr<std::unique_ptr<Store>> store = Store::Open(dir.path());
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(store.status().message()),
              HasSubstr("schema version 999, newer than this hdrstereod"));
  EXPECT_EQ(ReadFileOrDie(db_path), before);
}

TEST(SchemaTest, CorruptDatabaseIsRefusedAndLeftUntouched) {
  TempDir dir;
  const std::filesystem::path db_path = dir / "hdrstereo.db";
  const std::string garbage(8192, '\x5a');
  std::ofstream(db_path, std::ios::binary) << garbage;

  absl::StatusOr<std::unique_ptr<Store>> store = Store::Open(dir.path());
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(store.status().message()),
              HasSubstr("corrupt or not a SQLite file"));
  EXPECT_EQ(ReadFileOrDie(db_path), garbage);
}

TEST(SchemaTest, ForeignDatabaseWithoutVersionTableIsRefused) {
  TempDir dir;
  {
    absl::StatusOr<std::unique_ptr<Database>> db =
        Database::Open(dir / "hdrstereo.db");
    ASSERT_TRUE(db.ok());
    absl::MutexLock lock(&(*db)->mutex());
    ASSERT_TRUE((*db)->Exec("CREATE TABLE photos (id INTEGER)").ok());
  }
  absl::StatusOr<std::unique_ptr<Store>> store = Store::Open(dir.path());
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(store.status().message()),
              HasSubstr("not an hdrstereo database"));
}

// A database written before automatic bracketing (version 10, with the
// projector timing) with a capture: migration 11 gives it an empty
// auto_bracket (it chose no exposures at the rig) and keeps the rest.
TEST(SchemaTest, MigrationToAutoBracketLeavesOldCapturesWithoutOne) {
  constexpr int kBeforeAutoBracket = 10;
  TempDir dir;
  {
    ASSERT_OK_AND_ASSIGN(std::unique_ptr<Database> db,
                         Database::Open(dir / "hdrstereo.db"));
    ASSERT_OK_AND_ASSIGN(int version, Migrate(*db, kBeforeAutoBracket));
    ASSERT_EQ(version, kBeforeAutoBracket);
    Transaction tx(*db);
    ASSERT_OK(tx.status());
    ASSERT_OK(db->Exec(R"sql(
INSERT INTO sessions (name, create_time_ms) VALUES ('old', 0);
INSERT INTO captures (session_id, kind, plan, create_time_ms,
                      projector_refresh_hz)
VALUES (1, 'bracketed_stereo', 'fixed', 0, 60);
)sql"));
    EXPECT_THAT(
        db->Prepare("SELECT auto_bracket FROM captures").status(),
        StatusIs(absl::StatusCode::kInternal, HasSubstr("auto_bracket")));
    ASSERT_OK(tx.Commit());
  }
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<Store> store, Store::Open(dir.path()));
  EXPECT_EQ(store->schema_version(), LatestSchemaVersion());
  FrameRepository frames(*store);
  ASSERT_OK_AND_ASSIGN(const std::vector<CaptureRecord> captures,
                       frames.CapturesOfSession("old"));
  ASSERT_EQ(captures.size(), 1u);
  EXPECT_EQ(captures[0].plan, "fixed");
  EXPECT_EQ(captures[0].auto_bracket, "");
  ASSERT_OK_AND_ASSIGN(const ProjectorTiming timing,
                       frames.ProjectorTimingOf(captures[0].id));
  EXPECT_EQ(timing.refresh_hz, 60);
}

// A database written before the metrics (version 8) with a job and its
// events: migration 9 keeps them, counted as nothing (their kind is ''),
// and new events and device time are counted beside them.
TEST(SchemaTest, MigrationToMetricsKeepsOldEventsUncounted) {
  constexpr int kBeforeMetrics = 8;
  TempDir dir;
  {
    ASSERT_OK_AND_ASSIGN(std::unique_ptr<Database> db,
                         Database::Open(dir / "hdrstereo.db"));
    ASSERT_OK_AND_ASSIGN(int version, Migrate(*db, kBeforeMetrics));
    ASSERT_EQ(version, kBeforeMetrics);
    Transaction tx(*db);
    ASSERT_OK(tx.status());
    ASSERT_OK(db->Exec(R"sql(
INSERT INTO sessions (name, create_time_ms) VALUES ('old', 0);
INSERT INTO jobs (kind, session_id, state, request, create_time_ms)
VALUES ('capture', 1, 'failed', '', 0);
INSERT INTO job_events (job_id, sequence, time_ms, state, progress_done,
                        progress_total, level, message)
VALUES (1, 1, 0, 'failed', 0, 17, 'error', 'failed: camera timed out');
)sql"));
    EXPECT_THAT(db->Prepare("SELECT kind FROM job_events").status(),
                StatusIs(absl::StatusCode::kInternal, HasSubstr("kind")));
    ASSERT_OK(tx.Commit());
  }

  ASSERT_OK_AND_ASSIGN(std::unique_ptr<Store> store, Store::Open(dir.path()));
  EXPECT_EQ(store->schema_version(), LatestSchemaVersion());
  JobRepository jobs(*store);
  ASSERT_OK_AND_ASSIGN(std::vector<JobEventRecord> old, jobs.Events(1, 0));
  ASSERT_EQ(old.size(), 1u);
  EXPECT_EQ(old[0].message, "failed: camera timed out");
  EXPECT_EQ(old[0].tag.kind, EventKind::kNone);
  EXPECT_EQ(old[0].tag.seconds, std::nullopt);
  ASSERT_OK_AND_ASSIGN(StoreTotals before, MetricsRepository(*store).Read());
  EXPECT_EQ(before.events_by_kind.at(EventKind::kCameraTimeout), 0);

  ASSERT_OK(jobs.AddEvent(1, EventLevel::kWarning, "frame 3: previous file",
                          EventTag(EventKind::kPreviousFile))
                .status());
  ASSERT_OK(DeviceTimeRepository(*store).Record(
      1, {{.device = Device::kStage, .seconds = 1.25, .time_ms = 5}}));
  ASSERT_OK_AND_ASSIGN(StoreTotals after, MetricsRepository(*store).Read());
  EXPECT_EQ(after.events_by_kind.at(EventKind::kPreviousFile), 1);
  EXPECT_EQ(after.events_by_kind.at(EventKind::kCameraTimeout), 0);
  EXPECT_EQ(after.device_seconds.at(Device::kStage), std::vector<double>{1.25});
}

// A database written before the HTTP edge (version 13) with an audit row:
// migration 14 says it came over gRPC (the only transport then), and new
// rows keep the transport they are given.
TEST(SchemaTest, MigrationToTransportsCallsEarlierAuditRowsGrpc) {
  constexpr int kBeforeTransport = 13;
  TempDir dir;
  {
    ASSERT_OK_AND_ASSIGN(std::unique_ptr<Database> db,
                         Database::Open(dir / "hdrstereo.db"));
    ASSERT_OK_AND_ASSIGN(int version, Migrate(*db, kBeforeTransport));
    ASSERT_EQ(version, kBeforeTransport);
    Transaction tx(*db);
    ASSERT_OK(tx.status());
    ASSERT_OK(db->Exec(R"sql(
INSERT INTO audit (time_ms, principal, role, auth_method, peer, method,
                   status_code)
VALUES (5, 'bob', 'operator', 'cert', 'ipv4:10.0.0.9:4000',
        '/hdrstereo.v1.Sessions/Create', 0);
)sql"));
    EXPECT_THAT(db->Prepare("SELECT transport FROM audit").status(),
                StatusIs(absl::StatusCode::kInternal, HasSubstr("transport")));
    ASSERT_OK(tx.Commit());
  }
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<Store> store, Store::Open(dir.path()));
  EXPECT_EQ(store->schema_version(), LatestSchemaVersion());
  AuditRepository audit(*store);
  AuditRecord row;
  row.time_ms = 6;
  row.principal = "alice";
  row.role = "viewer";
  row.auth_method = "key:0a1b2c3d4e5f";
  row.transport = "http";
  row.peer = "ipv6:[::1]:8443";
  row.method = "/hdrstereo.v1.Sessions/Delete";
  row.status_code = 7;
  ASSERT_OK(audit.Append({row}));
  ASSERT_OK_AND_ASSIGN(std::vector<AuditRecord> rows, audit.List({}));
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].principal, "alice");
  EXPECT_EQ(rows[0].transport, "http");
  EXPECT_EQ(rows[0].peer, "ipv6:[::1]:8443");
  EXPECT_EQ(rows[1].principal, "bob");
  EXPECT_EQ(rows[1].transport, "grpc");
  EXPECT_EQ(rows[1].peer, "ipv4:10.0.0.9:4000");
}

}  // namespace
}  // namespace hdrstereo::store
