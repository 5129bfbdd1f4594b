// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Prometheus endpoint of a running daemon, scraped with libcurl after a
// simulated capture and compared with what the store records.
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

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/subprocess.h"

namespace hdrstereo {
namespace {

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

class MetricsTest : public testing::DaemonFixture {};

TEST_F(MetricsTest, ScrapeAfterSimulatedCaptureMatchesTheStore) {
  ListeningSocket probe;  // a free port, released for the daemon
  const int port = probe.port();
  probe.Close();
  StartDaemon({"--sim-scene",
               WriteScene("lab-lamp", testing::SmallLabLamp()).string(),
               "--metrics-listen", absl::StrCat("127.0.0.1:", port)});
  EXPECT_THAT(daemon_log(), HasSubstr(absl::StrCat(
                                "serving metrics on http://127.0.0.1:", port)));
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
