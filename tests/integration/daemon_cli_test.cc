// SPDX-License-Identifier: GPL-3.0-or-later
//
// The real hdrstereod binary on a free loopback port with a temporary data
// root, driven by the real hdrstereo CLI; the SQLite file is checked directly.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>

#include "daemon/store/database.h"
#include "daemon/store/schema.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::RunCommand;
using ::testing::HasSubstr;
using ::testing::Not;

class DaemonCliTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  // Runs hdrstereod expecting it to refuse to start.
  CommandResult RunDaemonExpectingFailure(const fs::path& root) {
    absl::StatusOr<CommandResult> result = RunCommand(
        {HDRSTEREOD, "--listen", "127.0.0.1:0", "--data-root", root.string(),
         "--log-file", (dir_ / "refused.log").string()},
        absl::Seconds(30));
    EXPECT_TRUE(result.ok()) << result.status();
    return result.value_or(CommandResult{});
  }
};

TEST_F(DaemonCliTest, StatusReportsServingAndVersions) {
  StartDaemon();
  CommandResult status = Cli({"status"});
  EXPECT_EQ(status.exit_code, 0) << status.err;
  EXPECT_THAT(status.out, HasSubstr("SERVING"));
  EXPECT_THAT(status.out, HasSubstr("hardware   sim"));
  EXPECT_THAT(status.out, HasSubstr(fs::canonical(data_root()).string()));

  CommandResult json = Cli({"--json", "status"});
  ASSERT_EQ(json.exit_code, 0) << json.err;
  nlohmann::json info = nlohmann::json::parse(json.out);
  EXPECT_EQ(info["schema_version"], store::LatestSchemaVersion());
  EXPECT_EQ(info["hardware_mode"], "sim");
  EXPECT_FALSE(info["version"].get<std::string>().empty());
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(DaemonCliTest, SessionLifecycleThroughTheCli) {
  StartDaemon();
  CommandResult create =
      Cli({"session", "create", "lab-1", "--note", "lamp scene"});
  ASSERT_EQ(create.exit_code, 0) << create.err;
  EXPECT_THAT(create.out, HasSubstr("created session lab-1"));
  ASSERT_EQ(Cli({"session", "create", "lab-2"}).exit_code, 0);

  CommandResult list = Cli({"session", "list"});
  ASSERT_EQ(list.exit_code, 0) << list.err;
  EXPECT_THAT(list.out, HasSubstr("NAME"));
  EXPECT_THAT(list.out, HasSubstr("lab-1"));
  EXPECT_THAT(list.out, HasSubstr("lamp scene"));
  EXPECT_THAT(list.out, HasSubstr("lab-2"));

  CommandResult show = Cli({"--json", "session", "show", "lab-1"});
  ASSERT_EQ(show.exit_code, 0) << show.err;
  nlohmann::json session = nlohmann::json::parse(show.out);
  EXPECT_EQ(session["name"], "lab-1");
  EXPECT_EQ(session["note"], "lamp scene");
  EXPECT_EQ(session["frame_count"], 0);
  const fs::path folder = session["path"].get<std::string>();
  EXPECT_TRUE(fs::is_directory(folder));
  EXPECT_EQ(folder, fs::canonical(data_root()) / "sessions" / "lab-1");

  // The database, read directly.
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "2");
  EXPECT_EQ(Sql("SELECT note FROM sessions WHERE name = 'lab-1'"),
            "lamp scene");

  CommandResult removed = Cli({"session", "delete", "lab-1", "--yes"});
  ASSERT_EQ(removed.exit_code, 0) << removed.err;
  EXPECT_THAT(removed.out, HasSubstr("deleted session lab-1"));
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions WHERE name = 'lab-1'"), "0");
  EXPECT_FALSE(fs::exists(folder));
  EXPECT_THAT(Cli({"session", "list"}).out, Not(HasSubstr("lab-1")));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(DaemonCliTest, BadRequestsGetClearErrorsAndChangeNothing) {
  StartDaemon();
  ASSERT_EQ(Cli({"session", "create", "keep", "--note", "original"}).exit_code,
            0);

  CommandResult bad_name = Cli({"session", "create", "two words"});
  EXPECT_EQ(bad_name.exit_code, 2);
  EXPECT_THAT(bad_name.err, HasSubstr("contains ' '"));

  CommandResult duplicate =
      Cli({"session", "create", "keep", "--note", "overwrite?"});
  EXPECT_EQ(duplicate.exit_code, 1);
  EXPECT_THAT(duplicate.err, HasSubstr("already exists"));

  CommandResult missing = Cli({"session", "show", "nope"});
  EXPECT_EQ(missing.exit_code, 4);
  EXPECT_THAT(missing.err, HasSubstr("no session named \"nope\""));

  CommandResult unconfirmed = Cli({"session", "delete", "keep"});
  EXPECT_EQ(unconfirmed.exit_code, 2);
  EXPECT_THAT(unconfirmed.err, HasSubstr("--yes"));

  EXPECT_EQ(Cli({"session", "delete", "nope", "--yes"}).exit_code, 4);

  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "1");
  EXPECT_EQ(Sql("SELECT note FROM sessions WHERE name = 'keep'"), "original");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(DaemonCliTest, UnreachableServerIsReportedInOneLine) {
  // Nothing listens on port 1 of loopback.
  address_ = "127.0.0.1:1";
  CommandResult result = Cli({"session", "list"});
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_THAT(result.err, HasSubstr("cannot reach hdrstereod at 127.0.0.1:1"));
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1);
}

TEST_F(DaemonCliTest, SessionsSurviveARestartAndShutdownIsClean) {
  StartDaemon();
  ASSERT_EQ(Cli({"session", "create", "persist"}).exit_code, 0);
  EXPECT_EQ(StopDaemon(), 0);
  EXPECT_THAT(ReadFileOrDie(data_root() / "logs" / "hdrstereod.log"),
              HasSubstr("stopped"));
  EXPECT_EQ(Sql("PRAGMA integrity_check"), "ok");

  StartDaemon();
  CommandResult list = Cli({"session", "list"});
  EXPECT_THAT(list.out, HasSubstr("persist"));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(DaemonCliTest, UnusableDataRootsAreRefusedWithoutChangingThem) {
  // A data root that is a file.
  std::ofstream(dir_ / "file-root") << "not a folder";
  CommandResult file_root = RunDaemonExpectingFailure(dir_ / "file-root");
  EXPECT_EQ(file_root.exit_code, 1);
  EXPECT_THAT(file_root.err, HasSubstr("is not a folder"));
  EXPECT_EQ(ReadFileOrDie(dir_ / "file-root"), "not a folder");

  // A corrupt database.
  fs::create_directories(dir_ / "corrupt");
  const std::string garbage(4096, 'G');
  std::ofstream(dir_ / "corrupt" / "hdrstereo.db", std::ios::binary) << garbage;
  CommandResult corrupt = RunDaemonExpectingFailure(dir_ / "corrupt");
  EXPECT_EQ(corrupt.exit_code, 1);
  EXPECT_THAT(corrupt.err, HasSubstr("corrupt or not a SQLite file"));
  EXPECT_EQ(ReadFileOrDie(dir_ / "corrupt" / "hdrstereo.db"), garbage);

  // A database from a newer hdrstereod.
  StartDaemon();
  ASSERT_EQ(Cli({"session", "create", "precious"}).exit_code, 0);
  ASSERT_EQ(StopDaemon(), 0);
  {
    absl::StatusOr<std::unique_ptr<store::Database>> db =
        store::Database::Open(data_root() / "hdrstereo.db");
    ASSERT_TRUE(db.ok());
    absl::MutexLock lock(&(*db)->mutex());
    ASSERT_TRUE((*db)
                    ->Exec("INSERT INTO schema_version VALUES (42, 0); "
                           "PRAGMA wal_checkpoint(TRUNCATE);")
                    .ok());
  }
  const std::string before = ReadFileOrDie(data_root() / "hdrstereo.db");
  CommandResult newer = RunDaemonExpectingFailure(data_root());
  EXPECT_EQ(newer.exit_code, 1);
  EXPECT_THAT(newer.err, HasSubstr("schema version 42, newer than"));
  EXPECT_EQ(ReadFileOrDie(data_root() / "hdrstereo.db"), before);
  EXPECT_EQ(Sql("SELECT name FROM sessions"), "precious");
}

TEST_F(DaemonCliTest, NonLoopbackListenAddressIsRefused) {
  absl::StatusOr<CommandResult> result =
      RunCommand({HDRSTEREOD, "--listen", "0.0.0.0:50051", "--data-root",
                  data_root().string()});
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result->exit_code, 2);
  EXPECT_THAT(result->err, HasSubstr("not a loopback address"));
  EXPECT_FALSE(fs::exists(data_root()));
}

}  // namespace
}  // namespace hdrstereo
