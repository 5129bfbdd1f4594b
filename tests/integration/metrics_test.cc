// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Prometheus endpoint of a running daemon, scraped with libcurl after
// simulated captures (with seeded faults) and processing, and compared with
// what the faults imply and what the store records.
#include <arpa/inet.h>
#include <curl/curl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/subprocess.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::testing::HasSubstr;
using ::testing::Not;

// A socket listening on 127.0.0.1 at a port the kernel picked.
class ListeningSocket {
 public:
  ListeningSocket() {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof(addr);
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), len) != 0 ||
        ::listen(fd_, 1) != 0 ||
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
      ADD_FAILURE() << "cannot listen on 127.0.0.1: " << strerror(errno);
      return;
    }
    port_ = ntohs(addr.sin_port);
  }
  ~ListeningSocket() { Close(); }
  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  int port() const { return port_; }

 private:
  int fd_ = -1;
  int port_ = 0;
};

size_t Append(char* data, size_t size, size_t count, void* out) {
  static_cast<std::string*>(out)->append(data, size * count);
  return size * count;
}

// GET http://127.0.0.1:<port>/metrics; the body, or "" with a test failure.
std::string Scrape(int port) {
  std::string body;
  CURL* curl = curl_easy_init();
  const std::string url = absl::StrCat("http://127.0.0.1:", port, "/metrics");
  curl_easy_setopt(curl, CURLOPT_URL, url.c_str());
  curl_easy_setopt(curl, CURLOPT_WRITEFUNCTION, Append);
  curl_easy_setopt(curl, CURLOPT_WRITEDATA, &body);
  curl_easy_setopt(curl, CURLOPT_TIMEOUT, 30L);
  const CURLcode code = curl_easy_perform(curl);
  long http = 0;
  curl_easy_getinfo(curl, CURLINFO_RESPONSE_CODE, &http);
  curl_easy_cleanup(curl);
  EXPECT_EQ(code, CURLE_OK) << curl_easy_strerror(code);
  EXPECT_EQ(http, 200);
  return body;
}

// The text format's samples, "name{labels}" -> value; comments skipped.
std::map<std::string, double> ParseSamples(const std::string& text) {
  std::map<std::string, double> samples;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.rfind(' ');
    double value = 0;
    EXPECT_TRUE(space != std::string::npos &&
                absl::SimpleAtod(line.substr(space + 1), &value))
        << "not a sample: " << line;
    samples[line.substr(0, space)] = value;
  }
  return samples;
}

class MetricsTest : public testing::DaemonFixture {
 protected:
  // Starts the daemon on simulated hardware (SmallLabLamp modified by
  // `patch`, simulated time 0) serving metrics on a free port; returns it.
  int StartWithMetrics(const nlohmann::json& patch = testing::SmallLabLamp()) {
    ListeningSocket probe;  // a free port, released for the daemon
    const int port = probe.port();
    probe.Close();
    StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string(),
                 "--sim-time-scale", "0", "--metrics-listen",
                 absl::StrCat("127.0.0.1:", port)});
    EXPECT_THAT(
        daemon_log(),
        HasSubstr(absl::StrCat("serving metrics on http://127.0.0.1:", port)));
    return port;
  }

  int64_t SqlCount(const std::string& query) {
    int64_t n = -1;
    EXPECT_TRUE(absl::SimpleAtoi(Sql(query), &n)) << query;
    return n;
  }
};

// The samples of the metric `name` by their labels: {"kind=\"corrupt\"": 0,
// ...}.
std::map<std::string, double> Series(const std::map<std::string, double>& m,
                                     const std::string& name) {
  std::map<std::string, double> out;
  const std::string prefix = absl::StrCat(name, "{");
  for (const auto& [key, value] : m) {
    if (absl::StartsWith(key, prefix) && absl::EndsWith(key, "}")) {
      out[key.substr(prefix.size(), key.size() - prefix.size() - 1)] = value;
    }
  }
  return out;
}

TEST_F(MetricsTest, ScrapeAfterSimulatedCaptureMatchesTheStore) {
  const int port = StartWithMetrics();
  ASSERT_EQ(Cli({"session", "create", "lab"}).exit_code, 0);
  testing::CommandResult capture = Cli({"capture", "stereo", "lab", "--watch"});
  ASSERT_EQ(capture.exit_code, 0) << capture.out << capture.err;

  std::map<std::string, double> m = ParseSamples(Scrape(port));
  // The bracketed stereo capture of the small scene takes 17 frames.
  ASSERT_EQ(Sql("SELECT count(*) FROM frames"), "17");
  EXPECT_EQ(m["hdrstereo_frames_captured_total"], 17);
  const std::string verified =
      Sql("SELECT count(*) FROM frames WHERE camera_file_name != '' OR "
          "camera_exposure_s IS NOT NULL");
  EXPECT_EQ(verified, "17");  // the simulated camera reports every frame
  EXPECT_EQ(m["hdrstereo_frames_verified_total"], 17);
  EXPECT_EQ(m["hdrstereo_jobs{state=\"succeeded\"}"], 1);
  for (const char* state :
       {"queued", "running", "paused", "failed", "cancelled", "interrupted"}) {
    const std::string key =
        absl::StrCat("hdrstereo_jobs{state=\"", state, "\"}");
    ASSERT_EQ(m.count(key), 1u) << key << " missing";
    EXPECT_EQ(m[key], 0) << key;
  }
  EXPECT_EQ(m["hdrstereo_suspensions_total"], 0);  // nothing suspended it
  // One frame time per frame after the first, every one within +Inf.
  EXPECT_EQ(m["hdrstereo_capture_frame_seconds_count"], 16);
  EXPECT_EQ(m["hdrstereo_capture_frame_seconds_bucket{le=\"+Inf\"}"], 16);
  EXPECT_EQ(m["hdrstereo_metrics_store_read_ok"], 1);
  // Free space as statvfs says, give or take what else writes meanwhile.
  const double free_bytes =
      static_cast<double>(std::filesystem::space(data_root()).available);
  EXPECT_NEAR(m["hdrstereo_data_root_free_bytes"], free_bytes, 64 << 20);
  EXPECT_GT(m["hdrstereo_data_root_free_bytes"], 0);
}

// Seeded faults, each fired once at a known call, give exactly the counts
// they imply, by kind, in the store and on the endpoint; every capture,
// stage move and projector pattern is one device-time sample; the counts
// are read from the store, so they survive a restart of the daemon.
TEST_F(MetricsTest, SeededFaultsAreCountedByKindAndDeviceCallsAreTimed) {
  // The small bracketed stereo capture: frame 0 (ambient) and 1-8 (left)
  // at 0 mm, 9-16 (right) at 150 mm. The simulated camera counts capture
  // calls from 1 per daemon run; a frame that fails its check is taken
  // once more (one more call), one that times out up to three times.
  nlohmann::json patch = testing::SmallLabLamp();
  patch["faults"] = {
      {"camera",
       {{"previous_file", {{"calls", {3}}}},   // frame 2, retaken by call 4
        {"wrong_exposure", {{"calls", {7}}}},  // frame 5, retaken by call 8
        {"card_target", {{"calls", {11}}}},    // frame 8, retaken by call 12
        {"timeout", {{"calls", {15, 16, 17}}}}}}};  // frame 11: it fails
  const int port = StartWithMetrics(patch);
  ASSERT_EQ(Cli({"session", "create", "lab"}).exit_code, 0);
  EXPECT_EQ(Cli({"capture", "stereo", "lab", "--watch"}).exit_code, 1);
  ASSERT_EQ(Sql("SELECT count(*) FROM frames"), "11");  // frames 0-10
  // The same plan again takes frames 11-16 (calls 18-23).
  CommandResult again = Cli({"capture", "stereo", "lab", "--watch"});
  ASSERT_EQ(again.exit_code, 0) << again.out << again.err;
  ASSERT_EQ(Sql("SELECT count(*) FROM frames"), "17");
  const std::map<std::string, double> before = ParseSamples(Scrape(port));

  // A new daemon (the stage controller's commands count from 1 again):
  // with the simulated time at 0, a capture's stage commands are 1 "get
  // maxspeed" at the start, the job's State() (2-3), the first frame's
  // conditions (4-5) and Home() (6-7), then its MoveTo: State() (8-9) and
  // "move abs" (10), whose three tries are all garbled: the frame is taken
  // again after homing, and the job goes on.
  EXPECT_EQ(StopDaemon(), 0);
  patch["faults"] = {{"stage", {{"garbled", {{"calls", {10, 11, 12}}}}}}};
  const int restarted = StartWithMetrics(patch);
  ASSERT_EQ(Cli({"session", "create", "garbled"}).exit_code, 0);
  EXPECT_EQ(Cli({"capture", "stereo", "garbled", "--watch"}).exit_code, 0);
  EXPECT_THAT(Sql("SELECT message FROM job_events WHERE job_id = 3 AND kind "
                  "= 'stage_garbled' AND level = 'warning'"),
              HasSubstr("answered \"move abs 0\" with garbage"));

  const std::map<std::string, double> m = ParseSamples(Scrape(restarted));
  const std::map<std::string, double> failures =
      Series(m, "hdrstereo_frame_verification_failures_total");
  EXPECT_EQ(failures,
            (std::map<std::string, double>{{R"(kind="previous_file")", 1},
                                           {R"(kind="wrong_exposure")", 1},
                                           {R"(kind="wrong_iso")", 0},
                                           {R"(kind="wrong_aperture")", 0},
                                           {R"(kind="card_target")", 1},
                                           {R"(kind="corrupt")", 0}}));
  // Read from the store: the restart lost none of them.
  EXPECT_EQ(Series(before, "hdrstereo_frame_verification_failures_total"),
            failures);
  // Each failure is the warning that took its frame again.
  for (const auto& [kind, message] :
       std::vector<std::pair<std::string, std::string>>{
           {"previous_file", "already taken in this capture"},
           {"wrong_exposure", "not the 1/"},
           {"card_target", "on its card, not in RAM"}}) {
    EXPECT_EQ(SqlCount(absl::StrCat(
                  "SELECT count(*) FROM job_events WHERE kind = '", kind,
                  "' AND level = 'warning' AND message LIKE '%", message,
                  "%taking it again'")),
              1)
        << kind;
  }
  EXPECT_EQ(Series(m, "hdrstereo_device_errors_total"),
            (std::map<std::string, double>{
                {R"(device="camera",kind="timeout")", 3},
                {R"(device="camera",kind="busy")", 0},
                {R"(device="camera",kind="disconnected")", 0},
                {R"(device="camera",kind="error")", 0},
                {R"(device="stage",kind="silent")", 0},
                {R"(device="stage",kind="garbled")", 1},
                {R"(device="stage",kind="stalled")", 0},
                {R"(device="stage",kind="flag")", 0},
                {R"(device="stage",kind="error")", 0},
                {R"(device="projector",kind="error")", 0}}));
  // Each device error is an event the job saw: the warnings that took the
  // frame again, and the failure after its third attempt.
  EXPECT_EQ(SqlCount("SELECT count(*) FROM job_events WHERE kind = "
                     "'camera_timeout' AND level = 'warning' AND job_id = 1"),
            2);
  EXPECT_THAT(Sql("SELECT message FROM job_events WHERE kind = "
                  "'camera_timeout' AND state = 'failed'"),
              HasSubstr("failed 3 times: 1) capturing: camera timed out "
                        "(simulated fault, call 15); 2) "));
  // Nothing else was counted.
  EXPECT_EQ(SqlCount("SELECT count(*) FROM job_events WHERE kind != ''"), 7);

  // Camera: 17 + 6 + 17 captures. Stage: job 1 homes, moves to 0 and 150
  // mm and to 150 mm again for the second and third attempt at frame 11;
  // job 2 moves to 150 mm and home at the end; job 3 homes, fails its move
  // to 0 mm, homes and moves to 0 mm again, then to 150 mm and home.
  // Projector: blank at the first frame of each job and at the second and
  // third attempts at frame 11 of job 1, and at the end of jobs 2 and 3.
  const std::map<std::string, double> calls =
      Series(m, "hdrstereo_device_seconds_count");
  EXPECT_EQ(calls,
            (std::map<std::string, double>{{R"(device="camera")", 40},
                                           {R"(device="stage")", 13},
                                           {R"(device="projector")", 7}}));
  for (const char* device : {"camera", "stage", "projector"}) {
    const std::string labels = absl::StrCat("device=\"", device, "\"");
    EXPECT_EQ(
        SqlCount(absl::StrCat(
            "SELECT count(*) FROM device_time WHERE device = '", device, "'")),
        calls.at(labels));
    EXPECT_EQ(m.at(absl::StrCat("hdrstereo_device_seconds_bucket{", labels,
                                ",le=\"+Inf\"}")),
              calls.at(labels));
  }
  EXPECT_EQ(m.at("hdrstereo_suspensions_total"), 0);
  EXPECT_EQ(m.at("hdrstereo_metrics_store_read_ok"), 1);
}

// A processing job gives one step-time sample per step it computed; a job
// that reuses every step gives none.
TEST_F(MetricsTest, EveryComputedProcessingStepIsOneSample) {
  const int port = StartWithMetrics();
  ASSERT_EQ(Cli({"session", "create", "lab"}).exit_code, 0);
  ASSERT_EQ(Cli({"capture", "stereo", "lab", "--watch"}).exit_code, 0);
  for (int run = 0; run < 2; ++run) {
    CommandResult process =
        Cli({"process", "lab", "--steps", "hdr", "--watch"});
    ASSERT_EQ(process.exit_code, 0) << process.out << process.err;
  }

  const std::map<std::string, double> m = ParseSamples(Scrape(port));
  // Every step of the pipeline has its series; hdr and what it needs ran
  // once (the second job reused them).
  std::map<std::string, double> expected;
  for (const char* step :
       {"decode", "rectify", "response", "hdr", "tonemap", "stereo", "fusion",
        "sl_groundtruth", "evaluate", "export", "report"}) {
    expected[absl::StrCat("step=\"", step, "\"")] = 0;
  }
  for (const char* step : {"decode", "rectify", "response", "hdr"}) {
    expected[absl::StrCat("step=\"", step, "\"")] = 1;
  }
  EXPECT_EQ(Series(m, "hdrstereo_processing_step_seconds_count"), expected);
  EXPECT_EQ(SqlCount("SELECT count(*) FROM job_events WHERE kind = "
                     "'step_computed' AND subject = 'hdr' AND seconds >= 0 "
                     "AND message LIKE 'hdr: computed in % s'"),
            1);
  EXPECT_EQ(SqlCount("SELECT count(*) FROM job_events WHERE kind = "
                     "'step_computed'"),
            4);
  EXPECT_GT(m.at("hdrstereo_processing_step_seconds_sum{step=\"hdr\"}"), 0);
}

TEST_F(MetricsTest, OffByDefault) {
  StartDaemon();
  EXPECT_THAT(daemon_log(), Not(HasSubstr("serving metrics")));
}

TEST_F(MetricsTest, TakenPortFailsTheStartNamingIt) {
  ListeningSocket taken;
  const std::string address = absl::StrCat("127.0.0.1:", taken.port());
  absl::StatusOr<testing::CommandResult> run = testing::RunCommand(
      {HDRSTEREOD, "--data-root", (dir_ / "data").string(), "--hardware", "sim",
       "--listen", "127.0.0.1:0", "--metrics-listen", address});
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_NE(run->exit_code, 0);
  EXPECT_THAT(run->out + run->err,
              HasSubstr(absl::StrCat("--metrics-listen \"", address,
                                     "\" cannot be served")));
}

TEST_F(MetricsTest, NonLoopbackAddressIsRefused) {
  absl::StatusOr<testing::CommandResult> run = testing::RunCommand(
      {HDRSTEREOD, "--data-root", (dir_ / "data").string(), "--hardware", "sim",
       "--metrics-listen", "0.0.0.0:9464"});
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_NE(run->exit_code, 0);
  EXPECT_THAT(run->err, HasSubstr("--metrics-listen \"0.0.0.0:9464\" is not a "
                                  "loopback address"));
}

}  // namespace
}  // namespace hdrstereo
