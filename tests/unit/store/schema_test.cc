// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/schema.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <string>

#include "daemon/store/store.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::store {
namespace {

using ::hdrstereo::testing::ReadFileOrDie;
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

}  // namespace
}  // namespace hdrstereo::store
