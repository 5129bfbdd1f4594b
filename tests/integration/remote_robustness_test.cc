// SPDX-License-Identifier: GPL-3.0-or-later
//
// Remote operation under stress, through the real TLS daemon: a Watch
// stream cut by the network resumes without a duplicate or a lost event;
// 100 TLS clients watch one capture; 10,000 calls with garbage credentials
// and method names neither crash the daemon nor grow it. Every loop is
// bounded in count and time; nothing here asserts a wall-clock duration.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <random>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"
#include "tests/integration/remote_fixture.h"
#include "tests/support/proto_methods.h"
#include "tests/support/tcp_proxy.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::Process;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::ResidentKb;
using ::hdrstereo::testing::TcpProxy;
using ::testing::HasSubstr;

// The top-level JSON objects of a text that holds several in a row.
std::vector<nlohmann::json> JsonObjects(const std::string& text) {
  std::vector<nlohmann::json> out;
  int depth = 0;
  bool quoted = false;
  size_t start = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        quoted = false;
      continue;
    }
    if (c == '"') quoted = true;
    if (c == '{' && depth++ == 0) start = i;
    if (c == '}' && --depth == 0) {
      out.push_back(nlohmann::json::parse(text.substr(start, i - start + 1)));
    }
  }
  return out;
}

class RemoteRobustnessTest : public testing::RemoteFixture {
 protected:
  // Every event of `job` on a fresh stream after `after`.
  static grpc::Status Events(const std::shared_ptr<grpc::Channel>& channel,
                             int64_t job, int64_t after,
                             std::vector<v1::JobEvent>* events) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::seconds(180));
    // Debian's gRPC 1.51 can fail a TCP connect that is still in progress
    // with a clobbered errno ("connect failed: No such file or directory";
    // grpc/grpc#35064, fixed upstream later): of 100 channels opened at once,
    // one now and then. Waiting for the channel to be ready retries that
    // connect with gRPC's backoff, as the CLI's watch reconnects.
    context.set_wait_for_ready(true);
    v1::WatchJobRequest request;
    request.set_job_id(job);
    request.set_after_sequence(after);
    auto reader = v1::Jobs::NewStub(channel)->Watch(&context, request);
    v1::JobEvent event;
    while (reader->Read(&event)) events->push_back(event);
    return reader->Finish();
  }
};

TEST_F(RemoteRobustnessTest, AWatchCutByTheNetworkResumesWithoutDuplicates) {
  // Real-time devices, so that the capture lasts seconds.
  StartTlsDaemon({"--sim-time-scale", "1"});
  ASSERT_EQ(As("bob", {"session", "create", "w"}).exit_code, 0);
  absl::StatusOr<std::unique_ptr<TcpProxy>> proxy = TcpProxy::Start(tls_port());
  ASSERT_TRUE(proxy.ok()) << proxy.status();
  std::vector<std::string> argv = {HDRSTEREO_CLI, "--server",
                                   (*proxy)->address()};
  std::vector<std::string> bob = certs_.CliArgs("bob");
  argv.insert(argv.end(), bob.begin(), bob.end());
  argv.insert(argv.end(), {"--json", "capture", "stereo", "w", "--exposures",
                           "1/30,1/60,1/125", "--watch"});
  const std::filesystem::path out = dir_ / "watch.out";
  // stdout and stderr go to one file; JSON objects and the CLI's notes.
  absl::StatusOr<Process> cli = Process::Start(argv, out);
  ASSERT_TRUE(cli.ok()) << cli.status();
  // Cut twice while events flow (at most 60 s each).
  int cuts = 0;
  for (int wanted : {3, 6}) {
    for (int i = 0; i < 600; ++i) {
      std::error_code ec;
      if (std::filesystem::exists(out, ec) &&
          JsonObjects(ReadFileOrDie(out)).size() >=
              static_cast<size_t>(wanted)) {
        break;
      }
      absl::SleepFor(absl::Milliseconds(100));
    }
    cuts += (*proxy)->CutAll();
  }
  std::optional<int> code = cli->Wait(absl::Seconds(180));
  ASSERT_TRUE(code.has_value()) << ReadFileOrDie(out);
  const std::string text = ReadFileOrDie(out);
  EXPECT_EQ(*code, 0) << text;
  EXPECT_GE(cuts, 2) << "the streams were not cut";
  EXPECT_GE((*proxy)->connections_accepted(), 2);
  EXPECT_THAT(text, HasSubstr("resuming after event"));

  std::vector<nlohmann::json> objects = JsonObjects(text);
  ASSERT_GE(objects.size(), 2u);
  const int64_t job = JsonInt(objects[0]["id"]);  // the submitted job
  std::vector<int64_t> sequences;
  for (size_t i = 1; i < objects.size(); ++i) {
    sequences.push_back(JsonInt(objects[i]["sequence"]));
  }
  // Every event exactly once, in order: 1, 2, ..., n.
  for (size_t i = 0; i < sequences.size(); ++i) {
    ASSERT_EQ(sequences[i], static_cast<int64_t>(i + 1)) << text;
  }
  EXPECT_EQ(objects.back().value("state", ""), "JOB_STATE_SUCCEEDED");
  // The daemon's own history has exactly as many events.
  EXPECT_EQ(
      Sql(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ", job)),
      absl::StrCat(sequences.size()));

  // after_sequence at the edges, on a plain stream.
  auto channel = TlsChannel("alice");
  std::vector<v1::JobEvent> tail;
  ASSERT_TRUE(Events(channel, job, 3, &tail).ok());
  ASSERT_FALSE(tail.empty());
  EXPECT_EQ(tail.front().sequence(), 4);
  EXPECT_EQ(tail.back().sequence(), static_cast<int64_t>(sequences.size()));
  std::vector<v1::JobEvent> none;
  EXPECT_TRUE(
      Events(channel, job, static_cast<int64_t>(sequences.size()), &none).ok());
  EXPECT_TRUE(none.empty());
  grpc::Status beyond =
      Events(channel, job, static_cast<int64_t>(sequences.size()) + 1, &none);
  EXPECT_EQ(beyond.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_EQ(Events(channel, job, -1, &none).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(RemoteRobustnessTest, AHundredTlsClientsWatchOneCapture) {
  StartTlsDaemon({"--sim-time-scale", "0.2"});
  ASSERT_EQ(As("bob", {"session", "create", "many"}).exit_code, 0);
  nlohmann::json job = AsJson(
      "bob", {"capture", "stereo", "many", "--exposures", "1/30,1/60,1/125"});
  const int64_t id = JsonInt(job["id"]);
  ASSERT_GT(id, 0);
  constexpr int kWatchers = 100;
  std::vector<std::vector<int64_t>> seen(kWatchers);
  std::vector<grpc::Status> status(kWatchers);
  std::vector<std::string> last_state(kWatchers);
  std::vector<std::thread> threads;
  for (int i = 0; i < kWatchers; ++i) {
    // A channel (and so a TLS connection) each.
    threads.emplace_back([&, i, channel = TlsChannel(i % 2 ? "alice" : "bob")] {
      std::vector<v1::JobEvent> events;
      status[i] = Events(channel, id, 0, &events);
      for (const v1::JobEvent& e : events) seen[i].push_back(e.sequence());
      if (!events.empty())
        last_state[i] = v1::JobState_Name(events.back().state());
    });
  }
  for (std::thread& t : threads) t.join();
  const std::string total =
      Sql(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ", id));
  for (int i = 0; i < kWatchers; ++i) {
    ASSERT_TRUE(status[i].ok()) << i << ": " << status[i].error_message();
    EXPECT_EQ(absl::StrCat(seen[i].size()), total) << i;
    for (size_t k = 0; k < seen[i].size(); ++k) {
      ASSERT_EQ(seen[i][k], static_cast<int64_t>(k + 1)) << i;
    }
    EXPECT_EQ(last_state[i], "JOB_STATE_SUCCEEDED") << i;
  }
  // The capture's own account of its overhead (compared with an unwatched
  // run by tests/bench/capture_overhead.sh; see docs/benchmarks.md).
  std::cout << Sql(absl::StrCat(
                   "SELECT message FROM job_events WHERE job_id = ", id,
                   " AND message LIKE '%in the daemon%'"))
            << "\n";
  EXPECT_EQ(As("alice", {"status"}).exit_code, 0);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(RemoteRobustnessTest, GarbageCredentialsNeitherCrashNorGrowTheDaemon) {
  StartTlsDaemon();
  // bob's certificate on every channel, so that only the garbage decides.
  std::vector<std::shared_ptr<grpc::Channel>> channels;
  for (int i = 0; i < 4; ++i) channels.push_back(TlsChannel("bob"));
  std::vector<std::string> methods;
  for (const testing::ProtoMethod& m : testing::AllProtoMethods()) {
    methods.push_back(m.full_name);
  }
  std::atomic<int> wrong{0};
  std::atomic<int> unauthenticated{0};
  std::atomic<int> unimplemented{0};
  std::string first_wrong;
  std::mutex first_wrong_mutex;
  auto flood = [&](int calls, uint32_t seed) {
    std::mt19937 random(seed);
    auto printable = [&](size_t length) {
      std::string s(length, ' ');
      for (char& c : s) c = static_cast<char>(0x20 + random() % 95);
      return s;
    };
    for (int i = 0; i < calls; ++i) {
      const bool real_method = random() % 2 == 0;
      const std::string method = real_method
                                     ? methods[random() % methods.size()]
                                     : "/" + printable(1 + random() % 60);
      std::string authorization;
      const bool with_header = !real_method ? random() % 2 == 0 : true;
      switch (random() % 4) {
        case 0:
          authorization = printable(random() % 2048);
          break;
        case 1:
          authorization = "Bearer " + printable(random() % 200);
          break;
        case 2:
          authorization = "Bearer hs_" + printable(12) + "_" + printable(64);
          break;
        default:
          authorization = "Bearer hs_0123456789ab_" + std::string(64, 'f');
      }
      grpc::Status s = Call(channels[i % channels.size()], method,
                            with_header ? &authorization : nullptr);
      if (s.error_code() == grpc::StatusCode::UNAUTHENTICATED) {
        ++unauthenticated;
      } else if (s.error_code() == grpc::StatusCode::UNIMPLEMENTED) {
        ++unimplemented;
      } else {
        ++wrong;
        std::lock_guard<std::mutex> lock(first_wrong_mutex);
        if (first_wrong.empty()) {
          first_wrong = absl::StrCat(method, ": ", s.error_code(), " ",
                                     s.error_message());
        }
      }
    }
  };
  auto run = [&](int calls_per_thread, uint32_t seed) {
    std::vector<std::thread> threads;
    for (uint32_t t = 0; t < 4; ++t) {
      threads.emplace_back(flood, calls_per_thread, seed + t);
    }
    for (std::thread& t : threads) t.join();
  };
  run(250, 1);  // warm up: connections, caches, the audit writer
  const int64_t before = ResidentKb(daemon_->pid());
  ASSERT_GT(before, 0);
  run(2500, 100);  // 10,000 calls
  const int64_t after = ResidentKb(daemon_->pid());
  EXPECT_EQ(wrong, 0) << first_wrong;
  EXPECT_EQ(unauthenticated + unimplemented, 11000);
  EXPECT_GT(unauthenticated, 0);
  EXPECT_GT(unimplemented, 0);
  std::cout << "daemon RSS before " << before << " kB, after 10,000 calls "
            << after << " kB\n";
#if defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer keeps freed memory in quarantine, so RSS grows by
  // design; its leak check at the daemon's exit (StopDaemon() == 0 below)
  // stands in for this one.
  std::cout << "built with AddressSanitizer: RSS not compared\n";
#else
  EXPECT_LE(after, before + before / 10)
      << "RSS grew from " << before << " kB to " << after << " kB";
#endif
  // Still serving, and every refusal is on record.
  EXPECT_EQ(As("bob", {"session", "create", "after"}).exit_code, 0);
  EXPECT_EQ(As("carol", {"audit", "--limit", "1"}).exit_code, 0);
  EXPECT_EQ(Sql("SELECT count(*) FROM audit WHERE status_code IN (12, 16)"),
            "11000");
  EXPECT_EQ(StopDaemon(), 0);
}

}  // namespace
}  // namespace hdrstereo
