// SPDX-License-Identifier: GPL-3.0-or-later
//
// The real hdrstereod binary on a free loopback port with a temporary data
// root, the real hdrstereo CLI, and direct reads of the SQLite file: what
// integration tests need.
#ifndef HDRSTEREO_TESTS_SUPPORT_DAEMON_FIXTURE_H_
#define HDRSTEREO_TESTS_SUPPORT_DAEMON_FIXTURE_H_

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "daemon/store/database.h"
#include "nlohmann/json.hpp"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::testing {

// A JSON merge patch for WriteScene: the bundled lab-lamp at 240 x 180 (a
// fifth of the default, same field of view) with a 128 x 96 projector (7 + 7
// Gray-code bits, 30 patterns per exposure), so that captures in tests are
// quick.
nlohmann::json SmallLabLamp();

// The simulated camera mode the suite runs in: HDRSTEREO_TEST_SIM_CAMERA
// ("" = the direct camera; "ptpip" or "ptpip:tiff16": through libgphoto2
// to the simulated PTP/IP camera), which StartDaemon passes on.
std::string TestSimCamera();
bool TestsThroughPtpIp();

// A 64-bit integer from the CLI's --json output (protobuf's JSON writes
// int64 as a string); 0 when it is neither a string nor a number.
int64_t JsonInt(const nlohmann::json& value);

class DaemonFixture : public ::testing::Test {
 protected:
  std::filesystem::path data_root() const { return dir_ / "data"; }

  // Starts hdrstereod (--hardware sim and --listen 127.0.0.1:0 unless
  // `extra` says otherwise) and waits until it serves. The CLI then talks to
  // the first address (a wildcard 0.0.0.0 through 127.0.0.1).
  void StartDaemon(const std::vector<std::string>& extra = {});
  // SIGTERM; returns the exit code.
  int StopDaemon();
  // SIGKILL: a crash.
  void KillDaemon();

  // Runs the CLI against the daemon, with cli_args_ (e.g. TLS options)
  // before `args`.
  CommandResult Cli(std::vector<std::string> args,
                    absl::Duration timeout = absl::Seconds(120));
  // Parses the CLI's --json output.
  nlohmann::json CliJson(std::vector<std::string> args);

  // One value (first column of the first row) read by a separate read-only
  // connection, as a person with the sqlite3 shell would.
  std::string Sql(const std::string& query);

  // Writes a bundled scene, modified by `patch` (a JSON merge patch, RFC
  // 7396), to the test folder and returns its path for --sim-scene.
  std::filesystem::path WriteScene(const std::string& bundled,
                                   const nlohmann::json& patch);

  // Polls `hdrstereo jobs show` until the job is in `state` (e.g.
  // "succeeded"); false after `timeout`.
  bool WaitForJobState(int64_t job_id, const std::string& state,
                       absl::Duration timeout = absl::Seconds(120));

  // Submits a job with the CLI (`args` such as {"capture", "sl", "lab"});
  // its id, 0 when it was refused.
  int64_t Submit(std::vector<std::string> args);
  // `hdrstereo jobs show ID` as JSON.
  nlohmann::json Job(int64_t id);
  // The job's progress: frames (or steps) done.
  int64_t FramesDone(int64_t id);
  // How many job events (of any job) have a message containing `pattern`
  // (an SQL LIKE pattern without the surrounding %).
  int64_t EventsLike(const std::string& pattern);
  // How many job events (of any job) carry the kind named `kind`
  // (job_events.kind, e.g. "camera_timeout"), as the metrics count them.
  int64_t EventsOfKind(const std::string& kind);

  // The session's capture store is consistent: every recorded frame's file
  // exists and matches its sha256; no file under captures/ lacks a row;
  // sequences are 0..n-1 per capture without gaps or duplicates; `expected`
  // frames in all; PRAGMA integrity_check is ok.
  void ExpectConsistentStore(const std::string& session, int expected);
  // Every frame file's own EXIF says what its row says: the exposure that
  // was set (within the 1/6 stop the check allows) and the camera-reported
  // values recorded with it; no frame is another one again (the same bytes,
  // or the same camera file name and time: a file name alone repeats, e.g.
  // capt0000.jpg for every RAM capture or a counter that starts again).
  // Returns how many frames were checked.
  int ExpectFilesMatchTheirRows(const std::string& session);
  // No temporary file (a write that never completed) anywhere in the data
  // root.
  void ExpectNoTempFiles();

  std::string daemon_log() const;

  // Calls `row` with the statement on each frame of `session` (in capture
  // and sequence order), selecting `columns` from frames f.
  void ForEachFrameRow(const std::string& session, const std::string& columns,
                       const std::function<void(store::Statement&)>& row);

  TempDir dir_;
  std::optional<Process> daemon_;
  std::string address_;                 // what the CLI connects to
  std::vector<std::string> addresses_;  // every address the daemon serves
  // The HTTP edge's base URLs ("https://127.0.0.1:PORT"), in --http-listen
  // order.
  std::vector<std::string> http_urls_;
  std::vector<std::string> cli_args_;  // given to every CLI call
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_DAEMON_FIXTURE_H_
