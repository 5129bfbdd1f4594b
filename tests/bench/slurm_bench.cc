// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Slurm path's overhead: one simulated session's pipeline run locally
// (hdrstereo-proc as a child process) and as a batch job on the single-node
// cluster of tests/support/slurm_cluster.h (sbatch, then squeue/scontrol
// every 100 ms until COMPLETED), on the same cores, so the ratio is the
// overhead, not a speed-up. Counters: the bytes of the session's frames
// (read) and of the artifacts recorded (written). Needs root and Slurm.
//
// BM_DaemonBatch/local and /slurm: the daemon's batch reprocessing of N
// simulated sessions (`hdrstereo process --sessions 'b-*' --force --watch`,
// submit to every result recorded) with --processing-backend local or
// slurm, both with two jobs of one pipeline thread at a time on this
// machine's two cores, so the ratio is again the overhead.
//   build/tests/bench/slurm_bench --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "daemon/processing/slurm_cli.h"
#include "hardware/sim/bundled_scenes.h"
#include "processing/base/status_macros.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/sim_session.h"
#include "tests/support/slurm_cluster.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kSteps = {"stereo"};

fs::path Session(testing::TempDir& dir) {
  static int n = 0;
  const fs::path session = dir / absl::StrCat("s", n++);
  if (!testing::CopyCachedSimSession(session).ok()) return {};
  return session;
}

int64_t FrameBytes(const fs::path& session) {
  int64_t bytes = 0;
  for (const auto& e : fs::recursive_directory_iterator(session / "captures")) {
    if (e.is_regular_file()) bytes += static_cast<int64_t>(e.file_size());
  }
  return bytes;
}

int64_t ArtifactBytes(const fs::path& session) {
  std::ifstream in(session / "pipeline_state.json");
  nlohmann::json state = nlohmann::json::parse(in, nullptr, false);
  int64_t bytes = 0;
  if (state.is_discarded()) return -1;
  for (const auto& [step, entry] : state["steps"].items()) {
    for (const auto& a : entry["artifacts"]) {
      bytes += a.value("size_bytes", int64_t{0});
    }
  }
  return bytes;
}

void SetBytes(benchmark::State& state, const fs::path& session) {
  state.counters["read_MB"] = static_cast<double>(FrameBytes(session)) / 1e6;
  state.counters["written_MB"] =
      static_cast<double>(ArtifactBytes(session)) / 1e6;
}

void BM_Local(benchmark::State& state) {
  testing::TempDir dir;
  fs::path session;
  for (auto _ : state) {
    state.PauseTiming();
    session = Session(dir);
    state.ResumeTiming();
    absl::StatusOr<testing::CommandResult> r = testing::RunCommand(
        {HDRSTEREO_PROC, "pipeline", "--session-dir", session.string(),
         "--steps", absl::StrJoin(kSteps, ","), "--threads", "2"},
        absl::Minutes(10));
    if (!r.ok() || r->exit_code != 0) {
      state.SkipWithError("local pipeline failed");
      return;
    }
  }
  SetBytes(state, session);
}

void BM_Slurm(benchmark::State& state) {
  if (std::optional<std::string> reason = testing::SlurmCluster::SkipReason()) {
    state.SkipWithError(reason->c_str());
    return;
  }
  absl::StatusOr<std::unique_ptr<testing::SlurmCluster>> cluster =
      testing::SlurmCluster::Start();
  if (!cluster.ok()) {
    state.SkipWithError(std::string(cluster.status().message()).c_str());
    return;
  }
  slurm::SlurmOptions options;
  options.proc_path = HDRSTEREO_PROC;
  options.cpus_per_task = 2;
  testing::TempDir dir;
  fs::path session;
  int job = 0;
  for (auto _ : state) {
    state.PauseTiming();
    session = Session(dir);
    const std::string name = absl::StrCat(++job);
    fs::create_directories(session / "jobs" / name);
    state.ResumeTiming();
    absl::StatusOr<std::vector<std::string>> argv = slurm::SbatchArgv(
        options, {.job_name = absl::StrCat("hdrstereo-", name),
                  .session_dir = session.string(),
                  .log_dir = (session / "jobs" / name).string(),
                  .steps = kSteps,
                  .force = false,
                  .job_dir = ""});
    absl::StatusOr<testing::CommandResult> r = (*cluster)->Run(*argv);
    absl::StatusOr<int64_t> id =
        r.ok() ? slurm::ParseSbatchOutput(r->out) : r.status();
    if (!id.ok()) {
      state.SkipWithError("sbatch failed");
      return;
    }
    std::string final_state;
    while (final_state.empty()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      absl::StatusOr<testing::CommandResult> q =
          (*cluster)->Run(slurm::SqueueArgv(*id));
      if (q.ok() && slurm::ParseSqueueOutput(q->out, *id).ok()) continue;
      absl::StatusOr<testing::CommandResult> c =
          (*cluster)->Run(slurm::ScontrolArgv(*id));
      absl::StatusOr<slurm::JobState> s =
          c.ok() ? slurm::ParseScontrolOutput(c->out, *id) : c.status();
      if (s.ok() && slurm::IsFinal(s->state)) final_state = s->state;
    }
    if (final_state != "COMPLETED") {
      state.SkipWithError(final_state.c_str());
      return;
    }
  }
  SetBytes(state, session);
}

// hdrstereod on a free loopback port with a data root in `dir`.
class Daemon {
 public:
  static absl::StatusOr<std::unique_ptr<Daemon>> Start(
      const fs::path& dir, std::vector<std::string> extra) {
    auto d = std::unique_ptr<Daemon>(new Daemon());
    const fs::path ready = dir / "ready";
    fs::remove(ready);
    std::vector<std::string> argv = {
        HDRSTEREOD,     "--data-root",  (dir / "data").string(),
        "--ready-file", ready.string(), "--listen",
        "127.0.0.1:0",  "--hardware",   "sim"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    ASSIGN_OR_RETURN(testing::Process process,
                     testing::Process::Start(argv, dir / "daemon.log"));
    d->process_.emplace(std::move(process));
    if (!testing::WaitForFile(ready, absl::Seconds(60))) {
      return absl::DeadlineExceededError("hdrstereod did not start");
    }
    std::ifstream in(ready);
    std::getline(in, d->address_);
    return d;
  }
  ~Daemon() {
    if (!process_) return;
    process_->Signal(SIGTERM);
    process_->Wait(absl::Seconds(60));
  }

  absl::Status Cli(std::vector<std::string> args) {
    args.insert(args.begin(), {HDRSTEREO_CLI, "--server", address_});
    ASSIGN_OR_RETURN(testing::CommandResult r,
                     testing::RunCommand(args, absl::Minutes(20)));
    if (r.exit_code != 0) {
      return absl::InternalError(
          absl::StrCat(absl::StrJoin(args, " "), ": ", r.out, r.err));
    }
    return absl::OkStatus();
  }

 private:
  Daemon() = default;
  std::optional<testing::Process> process_;
  std::string address_;
};

constexpr int kBatchSessions = 4;

void BM_DaemonBatch(benchmark::State& state) {
  const bool on_slurm = state.range(0) == 1;
  std::unique_ptr<testing::SlurmCluster> cluster;
  if (on_slurm) {
    if (std::optional<std::string> reason =
            testing::SlurmCluster::SkipReason()) {
      state.SkipWithError(reason->c_str());
      return;
    }
    absl::StatusOr<std::unique_ptr<testing::SlurmCluster>> started =
        testing::SlurmCluster::Start();
    if (!started.ok()) {
      state.SkipWithError(std::string(started.status().message()).c_str());
      return;
    }
    cluster = *std::move(started);
  }
  testing::TempDir dir;
  // The 240 x 180 lab-lamp of the integration tests.
  nlohmann::json scene;
  for (const sim::BundledScene& s : sim::BundledScenes()) {
    if (s.name == "lab-lamp")
      scene = nlohmann::json::parse(std::string(s.json));
  }
  scene.merge_patch(testing::SmallLabLamp());
  std::ofstream(dir / "scene.json") << scene.dump(2);
  std::vector<std::string> flags = {"--sim-scene",
                                    (dir / "scene.json").string(),
                                    "--processing-threads", "2"};
  if (on_slurm) {
    flags.insert(flags.end(),
                 {"--processing-backend", "slurm", "--slurm-conf",
                  cluster->conf().string(), "--slurm-proc-path", HDRSTEREO_PROC,
                  "--slurm-cpus-per-task", "1", "--slurm-poll-s", "0.1"});
  }
  absl::StatusOr<std::unique_ptr<Daemon>> daemon =
      Daemon::Start(dir.path(), flags);
  if (!daemon.ok()) {
    state.SkipWithError(std::string(daemon.status().message()).c_str());
    return;
  }
  for (int i = 0; i < kBatchSessions; ++i) {
    const std::string name = absl::StrCat("b-", i);
    absl::Status s = (*daemon)->Cli({"session", "create", name});
    if (s.ok()) s = (*daemon)->Cli({"capture", "stereo", name, "--watch"});
    if (!s.ok()) {
      state.SkipWithError(std::string(s.message()).c_str());
      return;
    }
  }
  for (auto _ : state) {
    absl::Status s =
        (*daemon)->Cli({"process", "--sessions", "b-*", "--steps",
                        absl::StrJoin(kSteps, ","), "--force", "--watch"});
    if (!s.ok()) {
      state.SkipWithError(std::string(s.message()).c_str());
      return;
    }
  }
  state.counters["sessions_per_s"] = benchmark::Counter(
      kBatchSessions * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate);
}

BENCHMARK(BM_Local)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(3);
BENCHMARK(BM_Slurm)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(3);
BENCHMARK(BM_DaemonBatch)
    ->ArgName("slurm")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(2);

}  // namespace
}  // namespace hdrstereo

BENCHMARK_MAIN();
