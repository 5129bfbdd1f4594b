// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/daemon_fixture.h"

#include <signal.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "daemon/store/database.h"
#include "hardware/sim/bundled_scenes.h"
#include "processing/io/atomic_file.h"
#include "processing/io/exif.h"
#include "processing/io/sha256.h"

namespace hdrstereo::testing {

namespace fs = std::filesystem;

int64_t JsonInt(const nlohmann::json& value) {
  if (value.is_string()) return std::stoll(value.get<std::string>());
  return value.is_number() ? value.get<int64_t>() : 0;
}

nlohmann::json SmallLabLamp() {
  return {{"camera",
           {{"width", 240},
            {"height", 180},
            {"fx", 320},
            {"fy", 320},
            {"cx", 119.5},
            {"cy", 89.5}}},
          {"projector", {{"width", 128}, {"height", 96}}}};
}

std::string TestSimCamera() {
  const char* mode = std::getenv("HDRSTEREO_TEST_SIM_CAMERA");
  return mode != nullptr ? mode : "";
}

bool TestsThroughPtpIp() { return absl::StartsWith(TestSimCamera(), "ptpip"); }

void DaemonFixture::StartDaemon(const std::vector<std::string>& extra) {
  const fs::path ready = dir_ / "ready";
  fs::remove(ready);
  std::vector<std::string> argv = {HDRSTEREOD, "--data-root",
                                   data_root().string(), "--ready-file",
                                   ready.string()};
  bool has_hardware = false;
  bool has_listen = false;
  for (const std::string& arg : extra) {
    has_hardware |= arg == "--hardware";
    has_listen |= arg == "--listen";
  }
  if (!has_hardware) {
    argv.push_back("--hardware");
    argv.push_back("sim");
    // The suite's camera mode (README "Tests"): HDRSTEREO_TEST_SIM_CAMERA
    // "ptpip" or "ptpip:FORMAT" drives the simulated camera through
    // libgphoto2 over PTP/IP (delivering FORMAT).
    const std::string mode = TestSimCamera();
    if (!mode.empty() &&
        std::find(extra.begin(), extra.end(), "--sim-camera") == extra.end()) {
      const std::vector<std::string> parts = absl::StrSplit(mode, ':');
      argv.push_back("--sim-camera");
      argv.push_back(parts[0]);
      if (parts.size() > 1) {
        argv.push_back("--sim-camera-format");
        argv.push_back(parts[1]);
      }
    }
  }
  if (!has_listen) {
    argv.push_back("--listen");
    argv.push_back("127.0.0.1:0");
  }
  argv.insert(argv.end(), extra.begin(), extra.end());
  absl::StatusOr<Process> process = Process::Start(argv, dir_ / "daemon.log");
  ASSERT_TRUE(process.ok()) << process.status();
  daemon_.emplace(*std::move(process));
  ASSERT_TRUE(WaitForFile(ready, absl::Seconds(60))) << daemon_log();
  // gRPC addresses, then the HTTP edge's URLs.
  addresses_.clear();
  http_urls_.clear();
  const std::string lines = ReadFileOrDie(ready);
  for (absl::string_view line :
       absl::StrSplit(absl::StripAsciiWhitespace(lines), '\n')) {
    (absl::StartsWith(line, "http") ? http_urls_ : addresses_)
        .emplace_back(line);
  }
  address_ = absl::StrReplaceAll(addresses_[0], {{"0.0.0.0:", "127.0.0.1:"}});
}

int DaemonFixture::StopDaemon() {
  if (!daemon_.has_value()) return -1;
  daemon_->Signal(SIGTERM);
  std::optional<int> code = daemon_->Wait(absl::Seconds(60));
  EXPECT_TRUE(code.has_value()) << "hdrstereod ignored SIGTERM";
  daemon_.reset();
  return code.value_or(-1);
}

void DaemonFixture::KillDaemon() {
  if (!daemon_.has_value()) return;
  daemon_->Signal(SIGKILL);
  daemon_->Wait(absl::Seconds(30));
  daemon_.reset();
}

CommandResult DaemonFixture::Cli(std::vector<std::string> args,
                                 absl::Duration timeout) {
  std::vector<std::string> argv = {HDRSTEREO_CLI, "--server", address_};
  argv.insert(argv.end(), cli_args_.begin(), cli_args_.end());
  argv.insert(argv.end(), args.begin(), args.end());
  absl::StatusOr<CommandResult> result = RunCommand(argv, timeout);
  EXPECT_TRUE(result.ok()) << result.status();
  return result.value_or(CommandResult{});
}

nlohmann::json DaemonFixture::CliJson(std::vector<std::string> args) {
  args.insert(args.begin(), "--json");
  CommandResult result = Cli(args);
  EXPECT_EQ(result.exit_code, 0) << result.err;
  nlohmann::json parsed = nlohmann::json::parse(result.out, nullptr, false);
  EXPECT_FALSE(parsed.is_discarded()) << result.out;
  return parsed;
}

std::string DaemonFixture::Sql(const std::string& query) {
  absl::StatusOr<std::unique_ptr<store::Database>> db = store::Database::Open(
      data_root() / "hdrstereo.db", store::Database::Mode::kReadOnly);
  EXPECT_TRUE(db.ok()) << db.status();
  if (!db.ok()) return "";
  absl::MutexLock lock(&(*db)->mutex());
  absl::StatusOr<store::Statement> stmt = (*db)->Prepare(query);
  EXPECT_TRUE(stmt.ok()) << stmt.status();
  if (!stmt.ok()) return "";
  absl::StatusOr<bool> row = stmt->Step();
  EXPECT_TRUE(row.ok()) << row.status();
  return row.ok() && *row ? stmt->ColumnText(0) : "<no row>";
}

fs::path DaemonFixture::WriteScene(const std::string& bundled,
                                   const nlohmann::json& patch) {
  for (const sim::BundledScene& scene : sim::BundledScenes()) {
    if (scene.name != bundled) continue;
    nlohmann::json json = nlohmann::json::parse(
        std::string(scene.json.data(), scene.json.size()));
    json.merge_patch(patch);
    const fs::path path = dir_ / (bundled + "-test.json");
    EXPECT_TRUE(io::WriteFileAtomically(path, json.dump(2)).ok());
    return path;
  }
  ADD_FAILURE() << "no bundled scene " << bundled;
  return {};
}

bool DaemonFixture::WaitForJobState(int64_t job_id, const std::string& state,
                                    absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  while (absl::Now() < deadline) {
    std::vector<std::string> argv = {HDRSTEREO_CLI, "--server", address_};
    argv.insert(argv.end(), cli_args_.begin(), cli_args_.end());
    argv.insert(argv.end(), {"--json", "jobs", "show", std::to_string(job_id)});
    absl::StatusOr<CommandResult> result = RunCommand(argv);
    if (result.ok() && result->exit_code == 0) {
      nlohmann::json job = nlohmann::json::parse(result->out, nullptr, false);
      if (!job.is_discarded() &&
          job.value("state", "") ==
              "JOB_STATE_" + absl::AsciiStrToUpper(state)) {
        return true;
      }
    }
    absl::SleepFor(absl::Milliseconds(50));
  }
  return false;
}

int64_t DaemonFixture::Submit(std::vector<std::string> args) {
  nlohmann::json job = CliJson(std::move(args));
  return job.contains("id") ? JsonInt(job["id"]) : 0;
}

nlohmann::json DaemonFixture::Job(int64_t id) {
  return CliJson({"jobs", "show", std::to_string(id)});
}

int64_t DaemonFixture::FramesDone(int64_t id) {
  const nlohmann::json job = Job(id);
  return job.contains("progress") ? JsonInt(job["progress"]["done"]) : 0;
}

void DaemonFixture::ForEachFrameRow(
    const std::string& session, const std::string& columns,
    const std::function<void(store::Statement&)>& row) {
  absl::StatusOr<std::unique_ptr<store::Database>> db = store::Database::Open(
      data_root() / "hdrstereo.db", store::Database::Mode::kReadOnly);
  ASSERT_TRUE(db.ok()) << db.status();
  absl::MutexLock lock(&(*db)->mutex());
  absl::StatusOr<store::Statement> stmt = (*db)->Prepare(absl::StrCat(
      "SELECT ", columns,
      " FROM frames f JOIN captures c ON c.id = f.capture_id JOIN sessions s "
      "ON s.id = c.session_id WHERE s.name = ?1 ORDER BY f.capture_id, "
      "f.sequence"));
  ASSERT_TRUE(stmt.ok()) << stmt.status();
  stmt->Bind(1, session);
  for (absl::StatusOr<bool> more = stmt->Step(); more.ok() && *more;
       more = stmt->Step()) {
    row(*stmt);
  }
}

void DaemonFixture::ExpectConsistentStore(const std::string& session,
                                          int expected) {
  const fs::path session_dir = data_root() / "sessions" / session;
  std::set<fs::path> recorded;
  std::map<int64_t, int> next_sequence;
  ForEachFrameRow(
      session, "f.capture_id, f.sequence, f.path, f.sha256",
      [&](store::Statement& frame) {
        const int64_t capture = frame.ColumnInt(0);
        EXPECT_EQ(frame.ColumnInt(1), next_sequence[capture]++)
            << "gap or duplicate in capture " << capture;
        const fs::path path = frame.ColumnText(2);
        absl::StatusOr<std::string> sha =
            io::Sha256HexOfFile(session_dir / path);
        EXPECT_EQ(sha.value_or("missing"), frame.ColumnText(3))
            << path << (sha.ok() ? " does not match its row" : " is missing");
        recorded.insert(path);
      });
  EXPECT_EQ(static_cast<int>(recorded.size()), expected);
  for (const auto& entry :
       fs::recursive_directory_iterator(session_dir / "captures")) {
    // truth/ holds the simulator's exact truth, not frames.
    if (entry.is_regular_file() &&
        entry.path().parent_path().filename() != "truth") {
      EXPECT_TRUE(recorded.contains(fs::relative(entry.path(), session_dir)))
          << "orphan file " << entry.path();
    }
  }
  EXPECT_EQ(Sql("PRAGMA integrity_check"), "ok");
}

int DaemonFixture::ExpectFilesMatchTheirRows(const std::string& session) {
  int checked = 0;
  std::set<std::string> names_and_times;
  std::set<std::string> hashes;
  ForEachFrameRow(
      session,
      "f.path, f.exposure_s, f.camera_exposure_s, f.iso, f.camera_file_name, "
      "f.camera_time_ms, f.sha256",
      [&](store::Statement& frame) {
        const std::string path = frame.ColumnText(0);
        const io::ExifInfo exif = io::ParseExifFromFile(
            ReadFileOrDie(data_root() / "sessions" / session / path));
        EXPECT_TRUE(exif.exposure_s.has_value()) << path;
        EXPECT_FALSE(frame.ColumnIsNull(2)) << path;
        EXPECT_LE(std::abs(std::log2(exif.exposure_s.value_or(0) /
                                     frame.ColumnDouble(1))),
                  1.0 / 6)
            << path << " was exposed " << exif.exposure_s.value_or(0)
            << " s, its row says " << frame.ColumnDouble(1) << " s";
        EXPECT_DOUBLE_EQ(exif.exposure_s.value_or(0), frame.ColumnDouble(2))
            << path;
        EXPECT_DOUBLE_EQ(exif.iso.value_or(0), frame.ColumnDouble(3)) << path;
        const std::string name_and_time = absl::StrCat(
            frame.ColumnText(4), " taken at ", frame.ColumnText(5), " ms");
        EXPECT_TRUE(names_and_times.insert(name_and_time).second)
            << path << ": camera file " << name_and_time << " twice";
        EXPECT_TRUE(hashes.insert(frame.ColumnText(6)).second)
            << path << ": the same bytes as another frame";
        ++checked;
      });
  return checked;
}

int64_t DaemonFixture::EventsLike(const std::string& pattern) {
  return std::stoll(Sql(absl::StrCat(
      "SELECT count(*) FROM job_events WHERE message LIKE '%", pattern, "%'")));
}

int64_t DaemonFixture::EventsOfKind(const std::string& kind) {
  return std::stoll(Sql(absl::StrCat(
      "SELECT count(*) FROM job_events WHERE kind = '", kind, "'")));
}

void DaemonFixture::ExpectNoTempFiles() {
  for (const auto& entry : fs::recursive_directory_iterator(data_root())) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos)
        << entry.path();
  }
}

std::string DaemonFixture::daemon_log() const {
  std::error_code ec;
  if (!fs::exists(dir_ / "daemon.log", ec)) return "";
  return ReadFileOrDie(dir_ / "daemon.log");
}

}  // namespace hdrstereo::testing
