// SPDX-License-Identifier: GPL-3.0-or-later
//
// The HTTP edge against gRPC (issue 35, "Measured"), in one run: one
// daemon::Server in this process (simulated rig, temporary data root),
// serving gRPC on 127.0.0.1:0 (the local principal) and HTTP on
// 127.0.0.1:0 (an API key of bob, operator, as Authorization: Bearer).
//   BM_GrpcUnary/<method>  a warm channel and stub
//   BM_HttpUnary/<method>  one libcurl easy handle reused (one kept-alive
//                          connection), POST /hdrstereo.v1.<method>, JSON
// for Server.GetInfo and Sessions.List (20 sessions): wall time per call,
// and the CPU time of the whole process per call (getrusage: the client,
// the edge and the services are all in it) as cpu_us_per_call.
//   BM_GrpcLiveView/<frames>  Hardware.StreamPreview on the gRPC stream
//   BM_HttpLiveView/<frames>  the same as a Connect stream of binary
//                             PreviewMessages, parsed as they arrive
// at max_fps = kMaxPreviewFps (the highest the daemon sends): frames per
// second delivered (first to last frame), CPU per frame, and the delay
// from the daemon's frame time to its arrival at the client.
//   BM_DaemonIdle  the daemon's own CPU while no call is made
// Afterwards the program prints the ratios (medians when run with
// --benchmark_repetitions) against the targets (HTTP/gRPC <= 2x per unary
// call, live view >= 0.9x frames/s) and exits 1 when one is missed.
#include <benchmark/benchmark.h>
#include <curl/curl.h>
#include <grpcpp/grpcpp.h>
#include <spdlog/spdlog.h>
#include <stdlib.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "daemon/rpc/hardware_service.h"
#include "daemon/server.h"
#include "hdrstereo/v1/hardware.grpc.pb.h"
#include "hdrstereo/v1/server.grpc.pb.h"
#include "hdrstereo/v1/sessions.grpc.pb.h"

namespace {

namespace fs = std::filesystem;
using namespace hdrstereo;

constexpr int kSessions = 20;

double ProcessCpuMicros() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto micros = [](const timeval& t) { return t.tv_sec * 1e6 + t.tv_usec; };
  return micros(usage.ru_utime) + micros(usage.ru_stime);
}

size_t AppendBody(char* data, size_t size, size_t count, void* user) {
  static_cast<std::string*>(user)->append(data, size * count);
  return size * count;
}

// The daemon, a gRPC channel to it and a kept-alive HTTP connection.
struct World {
  fs::path dir;
  std::unique_ptr<daemon::Server> server;
  std::shared_ptr<grpc::Channel> channel;
  std::string http_base;  // "http://127.0.0.1:PORT"
  std::string bearer;     // "Authorization: Bearer hs_..."
  CURL* curl = nullptr;   // the unary calls' handle, never freed
  curl_slist* json_headers = nullptr;
  bool ok = false;
};

World& TheWorld() {
  static World* const world = [] {
    auto* w = new World;
    char pattern[] = "/tmp/http_bench.XXXXXX";
    if (::mkdtemp(pattern) == nullptr) return w;
    w->dir = pattern;
    daemon::Config config;
    config.listen = {"127.0.0.1:0"};
    config.http_listen = {"127.0.0.1:0"};
    config.data_root = w->dir / "data";
    config.ready_file = w->dir / "ready";
    config.hardware = hardware::HardwareMode::kSim;
    config.users = {{"bob", "operator"}};
    absl::StatusOr<std::unique_ptr<daemon::Server>> server =
        daemon::Server::Start(config);
    if (!server.ok()) {
      std::fprintf(stderr, "daemon: %s\n", server.status().ToString().c_str());
      return w;
    }
    w->server = *std::move(server);
    // The ready file: the gRPC address, then the HTTP edge's base URL.
    std::ifstream ready(config.ready_file);
    std::string grpc_address;
    std::getline(ready, grpc_address);
    std::getline(ready, w->http_base);
    w->channel =
        grpc::CreateChannel(grpc_address, grpc::InsecureChannelCredentials());
    v1::Sessions::Stub sessions(w->channel);
    for (int i = 0; i < kSessions; ++i) {
      grpc::ClientContext context;
      v1::CreateSessionRequest request;
      request.set_name(absl::StrCat("bench-", i));
      request.set_note("a session for http_bench");
      v1::Session session;
      if (grpc::Status s = sessions.Create(&context, request, &session);
          !s.ok()) {
        std::fprintf(stderr, "Sessions.Create: %s\n",
                     s.error_message().c_str());
        return w;
      }
    }
    absl::StatusOr<rpc::NewApiKey> key = w->server->api_keys().Create(
        "bob", rpc::Role::kOperator, absl::Hours(2), "http_bench", "bench");
    if (!key.ok()) {
      std::fprintf(stderr, "API key: %s\n", key.status().ToString().c_str());
      return w;
    }
    w->bearer = absl::StrCat("Authorization: Bearer ", key->token);
    w->curl = curl_easy_init();
    for (const char* header : {"Content-Type: application/json", "Expect:"}) {
      w->json_headers = curl_slist_append(w->json_headers, header);
    }
    w->json_headers = curl_slist_append(w->json_headers, w->bearer.c_str());
    curl_easy_setopt(w->curl, CURLOPT_HTTPHEADER, w->json_headers);
    curl_easy_setopt(w->curl, CURLOPT_POSTFIELDS, "{}");
    curl_easy_setopt(w->curl, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(w->curl, CURLOPT_WRITEFUNCTION, AppendBody);
    w->ok = !w->http_base.empty() && w->curl != nullptr;
    return w;
  }();
  return *world;
}

// ----- unary calls -----

bool GrpcCall(const std::string& method, v1::Server::Stub& server,
              v1::Sessions::Stub& sessions) {
  grpc::ClientContext context;
  if (method == "Server/GetInfo") {
    v1::ServerInfo info;
    return server.GetInfo(&context, {}, &info).ok();
  }
  v1::ListSessionsResponse list;
  return sessions.List(&context, {}, &list).ok() &&
         list.sessions_size() == kSessions;
}

// One POST on the kept-alive handle; false unless 200 with a body.
bool HttpCall(World& w, const std::string& url, std::string& body) {
  body.clear();
  curl_easy_setopt(w.curl, CURLOPT_URL, url.c_str());
  curl_easy_setopt(w.curl, CURLOPT_WRITEDATA, &body);
  long status = 0;
  return curl_easy_perform(w.curl) == CURLE_OK &&
         curl_easy_getinfo(w.curl, CURLINFO_RESPONSE_CODE, &status) ==
             CURLE_OK &&
         status == 200 && body.size() > 2;
}

void ReportCpu(benchmark::State& state, double cpu0) {
  state.counters["cpu_us_per_call"] =
      (ProcessCpuMicros() - cpu0) / static_cast<double>(state.iterations());
}

void BM_GrpcUnary(benchmark::State& state, const char* method) {
  World& w = TheWorld();
  v1::Server::Stub server(w.channel);
  v1::Sessions::Stub sessions(w.channel);
  if (!w.ok || !GrpcCall(method, server, sessions)) {
    state.SkipWithError("setup or first call failed");
    return;
  }
  const double cpu0 = ProcessCpuMicros();
  for (auto _ : state) {
    if (!GrpcCall(method, server, sessions)) state.SkipWithError("call failed");
  }
  ReportCpu(state, cpu0);
}

void BM_HttpUnary(benchmark::State& state, const char* method) {
  World& w = TheWorld();
  const std::string url = absl::StrCat(w.http_base, "/hdrstereo.v1.", method);
  std::string body;
  if (!w.ok || !HttpCall(w, url, body)) {
    state.SkipWithError(("setup or first call failed: " + body).c_str());
    return;
  }
  long connects = 0;
  const double cpu0 = ProcessCpuMicros();
  for (auto _ : state) {
    if (!HttpCall(w, url, body)) state.SkipWithError(body.c_str());
    long opened = 0;
    curl_easy_getinfo(w.curl, CURLINFO_NUM_CONNECTS, &opened);
    connects += opened;
  }
  ReportCpu(state, cpu0);
  // 0: every call went over the one kept-alive connection.
  state.counters["new_connections"] = static_cast<double>(connects);
}

// What the daemon's own threads use while no call is made (its job engine,
// scheduler, disk guard, webhook outbox): part of every cpu_us_per_call
// above, in proportion to the call's wall time.
void BM_DaemonIdle(benchmark::State& state) {
  if (!TheWorld().ok) {
    state.SkipWithError("setup failed");
    return;
  }
  const double cpu0 = ProcessCpuMicros();
  for (auto _ : state) absl::SleepFor(absl::Milliseconds(100));
  state.counters["cpu_us_per_s"] =
      (ProcessCpuMicros() - cpu0) / (state.iterations() * 0.1);
}

BENCHMARK(BM_DaemonIdle)->Iterations(10)->UseRealTime();
BENCHMARK_CAPTURE(BM_GrpcUnary, GetInfo, "Server/GetInfo")->UseRealTime();
BENCHMARK_CAPTURE(BM_HttpUnary, GetInfo, "Server/GetInfo")->UseRealTime();
BENCHMARK_CAPTURE(BM_GrpcUnary, SessionsList, "Sessions/List")->UseRealTime();
BENCHMARK_CAPTURE(BM_HttpUnary, SessionsList, "Sessions/List")->UseRealTime();

// ----- live view -----

v1::StreamPreviewRequest PreviewRequest(int frames) {
  v1::StreamPreviewRequest request;
  request.set_max_fps(rpc::HardwareService::kMaxPreviewFps);
  request.set_max_frames(frames);
  return request;
}

// The frames of one stream as they arrive.
struct Arrivals {
  std::vector<absl::Time> at;
  absl::Duration delay;  // summed: frame time to arrival
  double bytes = 0;
  int64_t last_sequence = 0;

  void Add(const v1::PreviewFrame& frame) {
    const absl::Time now = absl::Now();
    at.push_back(now);
    delay += now - (absl::FromUnixSeconds(frame.time().seconds()) +
                    absl::Nanoseconds(frame.time().nanos()));
    bytes += static_cast<double>(frame.jpeg().size());
    last_sequence = frame.sequence();
  }
};

// Frames per second from the first frame to the last, CPU per frame, the
// mean delay and the JPEG size; an error when frames are missing.
void ReportStream(benchmark::State& state, const Arrivals& arrivals,
                  double cpu_us, int frames) {
  const int n = static_cast<int>(arrivals.at.size());
  if (n != frames || arrivals.last_sequence != frames) {
    state.SkipWithError(absl::StrCat(n, " frames arrived (last sequence ",
                                     arrivals.last_sequence, "), not ", frames)
                            .c_str());
    return;
  }
  state.counters["fps"] =
      (n - 1) / absl::ToDoubleSeconds(arrivals.at.back() - arrivals.at.front());
  state.counters["cpu_ms_per_frame"] = cpu_us / 1e3 / n;
  state.counters["delay_ms"] = absl::ToDoubleMilliseconds(arrivals.delay) / n;
  state.counters["jpeg_kB"] = arrivals.bytes / 1e3 / n;
}

void BM_GrpcLiveView(benchmark::State& state) {
  World& w = TheWorld();
  if (!w.ok) {
    state.SkipWithError("setup failed");
    return;
  }
  const int frames = static_cast<int>(state.range(0));
  v1::Hardware::Stub hardware(w.channel);
  for (auto _ : state) {
    Arrivals arrivals;
    const double cpu0 = ProcessCpuMicros();
    grpc::ClientContext context;
    std::unique_ptr<grpc::ClientReader<v1::PreviewMessage>> reader =
        hardware.StreamPreview(&context, PreviewRequest(frames));
    v1::PreviewMessage message;
    while (reader->Read(&message)) {
      if (message.has_frame()) arrivals.Add(message.frame());
    }
    const grpc::Status status = reader->Finish();
    const double cpu_us = ProcessCpuMicros() - cpu0;
    if (!status.ok()) {
      state.SkipWithError(status.error_message().c_str());
      break;
    }
    ReportStream(state, arrivals, cpu_us, frames);
  }
}

// A Connect stream's body as it arrives: 5-byte envelopes (flags, big-endian
// length), each message parsed when complete.
struct EnvelopeReader {
  std::string buffer;
  Arrivals arrivals;
  std::string end_stream;  // the end-of-stream message's JSON
  bool malformed = false;

  static size_t OnData(char* data, size_t size, size_t count, void* user) {
    auto* self = static_cast<EnvelopeReader*>(user);
    self->buffer.append(data, size * count);
    self->Parse();
    return size * count;
  }

  void Parse() {
    size_t at = 0;
    while (buffer.size() - at >= 5) {
      const auto* prefix = reinterpret_cast<const uint8_t*>(buffer.data() + at);
      const uint32_t length = uint32_t{prefix[1]} << 24 |
                              uint32_t{prefix[2]} << 16 |
                              uint32_t{prefix[3]} << 8 | prefix[4];
      if (buffer.size() - at - 5 < length) break;
      const std::string payload = buffer.substr(at + 5, length);
      at += 5 + length;
      if (prefix[0] == 0x02) {
        end_stream = payload;
        continue;
      }
      v1::PreviewMessage message;
      if (prefix[0] != 0 || !message.ParseFromString(payload)) {
        malformed = true;
      } else if (message.has_frame()) {
        arrivals.Add(message.frame());
      }
    }
    buffer.erase(0, at);
  }
};

void BM_HttpLiveView(benchmark::State& state) {
  World& w = TheWorld();
  if (!w.ok) {
    state.SkipWithError("setup failed");
    return;
  }
  const int frames = static_cast<int>(state.range(0));
  const std::string request = PreviewRequest(frames).SerializeAsString();
  std::string body = {0, static_cast<char>(request.size() >> 24),
                      static_cast<char>(request.size() >> 16),
                      static_cast<char>(request.size() >> 8),
                      static_cast<char>(request.size())};
  body += request;
  const std::string url =
      absl::StrCat(w.http_base, "/hdrstereo.v1.Hardware/StreamPreview");
  curl_slist* headers = nullptr;
  for (const char* header :
       {"Content-Type: application/connect+proto", "Expect:"}) {
    headers = curl_slist_append(headers, header);
  }
  headers = curl_slist_append(headers, w.bearer.c_str());
  // Its own handle: the edge closes a connection after a stream.
  CURL* curl = curl_easy_init();
  curl_easy_setopt(curl, CURLOPT_URL, url.c_str());
  curl_easy_setopt(curl, CURLOPT_HTTPHEADER, headers);
  curl_easy_setopt(curl, CURLOPT_POSTFIELDS, body.data());
  curl_easy_setopt(curl, CURLOPT_POSTFIELDSIZE_LARGE,
                   static_cast<curl_off_t>(body.size()));
  curl_easy_setopt(curl, CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(curl, CURLOPT_WRITEFUNCTION, EnvelopeReader::OnData);
  for (auto _ : state) {
    EnvelopeReader reader;
    curl_easy_setopt(curl, CURLOPT_WRITEDATA, &reader);
    const double cpu0 = ProcessCpuMicros();
    const CURLcode code = curl_easy_perform(curl);
    const double cpu_us = ProcessCpuMicros() - cpu0;
    long status = 0;
    curl_easy_getinfo(curl, CURLINFO_RESPONSE_CODE, &status);
    if (code != CURLE_OK || status != 200 || reader.malformed ||
        reader.end_stream != "{}") {
      state.SkipWithError(absl::StrCat("HTTP ", status, ", ",
                                       curl_easy_strerror(code), ", end ",
                                       reader.end_stream)
                              .c_str());
      break;
    }
    ReportStream(state, reader.arrivals, cpu_us, frames);
  }
  curl_easy_cleanup(curl);
  curl_slist_free_all(headers);
}

// One stream per iteration, a few seconds each: repeat with
// --benchmark_repetitions rather than iterating.
BENCHMARK(BM_GrpcLiveView)->Arg(30)->Iterations(1)->UseRealTime();
BENCHMARK(BM_HttpLiveView)->Arg(30)->Iterations(1)->UseRealTime();

// ----- the summary -----

// Keeps every run for the summary while the console shows them.
class Collector final : public benchmark::ConsoleReporter {
 public:
  // Counters as name=value on each line: the cases have different ones.
  Collector() : ConsoleReporter(OO_None) {}
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.error_occurred) {
        failed_ = true;
      } else if (run.run_type == Run::RT_Aggregate) {
        if (run.aggregate_name == "median") {
          medians_[run.run_name.function_name] = run;
        }
      } else {
        runs_[run.run_name.function_name].push_back(run);
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }

  bool failed() const { return failed_; }

  // The median over repetitions (Google Benchmark's, or of the runs shown)
  // of the wall time per iteration in us (`counter` empty) or a counter;
  // -1 when the benchmark did not run.
  double Median(const std::string& name, const std::string& counter) const {
    auto value = [&](const Run& run) {
      if (counter.empty()) {
        return run.real_accumulated_time * 1e6 /
               static_cast<double>(run.iterations);
      }
      auto it = run.counters.find(counter);
      return it == run.counters.end() ? -1.0 : it->second.value;
    };
    if (auto it = medians_.find(name); it != medians_.end()) {
      return value(it->second);
    }
    auto it = runs_.find(name);
    if (it == runs_.end() || it->second.empty()) return -1;
    std::vector<double> values;
    for (const Run& run : it->second) values.push_back(value(run));
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
  }

 private:
  bool failed_ = false;
  std::map<std::string, Run> medians_;
  std::map<std::string, std::vector<Run>> runs_;
};

// Prints the ratios; false when a target is missed or a case did not run.
bool Summary(const Collector& c) {
  bool pass = !c.failed();
  std::printf("\nHTTP edge vs gRPC (medians over repetitions)\n");
  for (const char* method : {"GetInfo", "SessionsList"}) {
    const std::string grpc = absl::StrCat("BM_GrpcUnary/", method);
    const std::string http = absl::StrCat("BM_HttpUnary/", method);
    const double grpc_us = c.Median(grpc, "");
    const double http_us = c.Median(http, "");
    const double grpc_cpu = c.Median(grpc, "cpu_us_per_call");
    const double http_cpu = c.Median(http, "cpu_us_per_call");
    if (grpc_us <= 0 || http_us <= 0) {
      std::printf("  %-13s not measured (both cases must run)\n", method);
      continue;
    }
    const double ratio = http_us / grpc_us;
    pass &= ratio <= 2.0;
    std::printf(
        "  %-13s gRPC %7.1f us, HTTP %7.1f us: %.2fx (target <= 2x: %s); "
        "CPU per call gRPC %.1f us, HTTP %.1f us (%+.1f us, %.2fx)\n",
        method, grpc_us, http_us, ratio, ratio <= 2.0 ? "PASS" : "FAIL",
        grpc_cpu, http_cpu, http_cpu - grpc_cpu, http_cpu / grpc_cpu);
  }
  const double grpc_fps = c.Median("BM_GrpcLiveView", "fps");
  const double http_fps = c.Median("BM_HttpLiveView", "fps");
  if (grpc_fps > 0 && http_fps > 0) {
    const double ratio = http_fps / grpc_fps;
    pass &= ratio >= 0.9;
    std::printf(
        "  live view     gRPC %.2f frames/s, HTTP %.2f frames/s: %.3fx "
        "(target >= 0.9x: %s; max_fps %g); CPU per frame gRPC %.1f ms, HTTP "
        "%.1f ms; delay gRPC %.2f ms, HTTP %.2f ms\n",
        grpc_fps, http_fps, ratio, ratio >= 0.9 ? "PASS" : "FAIL",
        rpc::HardwareService::kMaxPreviewFps,
        c.Median("BM_GrpcLiveView", "cpu_ms_per_frame"),
        c.Median("BM_HttpLiveView", "cpu_ms_per_frame"),
        c.Median("BM_GrpcLiveView", "delay_ms"),
        c.Median("BM_HttpLiveView", "delay_ms"));
  } else {
    std::printf("  live view     not measured (both cases must run)\n");
  }
  return pass;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  curl_global_init(CURL_GLOBAL_DEFAULT);
  // The daemon's start-up lines would interleave with the table.
  spdlog::set_level(spdlog::level::warn);
  Collector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  benchmark::Shutdown();
  const bool pass = Summary(collector);
  World& w = TheWorld();
  if (w.server != nullptr) w.server->Shutdown();
  std::error_code ec;
  fs::remove_all(w.dir, ec);
  return pass ? 0 : 1;
}
