// SPDX-License-Identifier: GPL-3.0-or-later
//
// The pipeline as one Slurm batch job on a real single-node cluster
// (tests/support/slurm_cluster.h), submitted with the argument lists of
// daemon/processing/slurm_cli.h and followed through squeue and scontrol:
// the same artifacts (sha256) as a local run, a node-side failure carrying
// the pipeline's message, scancel mid-run. Skips, saying why, when not root
// or Slurm is not installed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "daemon/processing/slurm_cli.h"
#include "processing/base/status_macros.h"
#include "processing/io/sha256.h"
#include "tests/support/proc_tool.h"
#include "tests/support/sim_session.h"
#include "tests/support/slurm_cluster.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using testing::CommandResult;
using ::testing::HasSubstr;
using testing::SlurmCluster;

// Long enough for the small simulated session on two busy cores.
constexpr absl::Duration kJobTimeout = absl::Minutes(4);

class SlurmTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> reason = SlurmCluster::SkipReason()) {
      GTEST_SKIP() << *reason;
    }
    absl::StatusOr<std::unique_ptr<SlurmCluster>> cluster =
        SlurmCluster::Start();
    ASSERT_TRUE(cluster.ok()) << cluster.status();
    cluster_ = *std::move(cluster);
    options_.proc_path = HDRSTEREO_PROC;
    options_.cpus_per_task = 2;
  }

  fs::path NewSession(const std::string& name) {
    const fs::path dir = dir_ / name;
    absl::Status s = testing::CopyCachedSimSession(dir);
    EXPECT_TRUE(s.ok()) << s;
    return dir;
  }

  // sbatch; the Slurm job id.
  int64_t Submit(const fs::path& session, const std::vector<std::string>& steps,
                 const std::string& name) {
    absl::StatusOr<std::vector<std::string>> argv = slurm::SbatchArgv(
        options_, {.job_name = absl::StrCat("hdrstereo-", name),
                   .session_dir = session.string(),
                   .log_dir = (session / "jobs" / name).string(),
                   .steps = steps,
                   .force = false,
                   .job_dir = ""});
    EXPECT_TRUE(argv.ok()) << argv.status();
    fs::create_directories(session / "jobs" / name);
    absl::StatusOr<CommandResult> r = cluster_->Run(*argv);
    EXPECT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(r->exit_code, 0) << r->err;
    absl::StatusOr<int64_t> id = slurm::ParseSbatchOutput(r->out);
    EXPECT_TRUE(id.ok()) << id.status();
    return id.value_or(0);
  }

  absl::StatusOr<slurm::JobState> State(int64_t id) {
    ASSIGN_OR_RETURN(CommandResult q, cluster_->Run(slurm::SqueueArgv(id)));
    absl::StatusOr<slurm::JobState> s = slurm::ParseSqueueOutput(q.out, id);
    if (s.ok() && !slurm::IsFinal(s->state)) return s;
    // Left the queue (or finished in it): scontrol has the final state.
    ASSIGN_OR_RETURN(CommandResult c, cluster_->Run(slurm::ScontrolArgv(id)));
    return slurm::ParseScontrolOutput(c.out, id);
  }

  // Polls until `done(state)`; the states seen, described, in `seen`.
  slurm::JobState WaitFor(
      int64_t id, const std::function<bool(const slurm::JobState&)>& done,
      std::vector<std::string>* seen = nullptr) {
    const absl::Time deadline = absl::Now() + kJobTimeout;
    slurm::JobState last;
    while (absl::Now() < deadline) {
      absl::StatusOr<slurm::JobState> s = State(id);
      EXPECT_TRUE(s.ok()) << s.status();
      if (!s.ok()) return last;
      last = *s;
      if (seen != nullptr &&
          (seen->empty() || seen->back() != slurm::Describe(last))) {
        seen->push_back(slurm::Describe(last));
      }
      if (done(last)) return last;
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
    ADD_FAILURE() << "Slurm job " << id << " still " << slurm::Describe(last)
                  << " after " << absl::FormatDuration(kJobTimeout);
    return last;
  }

  slurm::JobState WaitForEnd(int64_t id, std::vector<std::string>* seen) {
    return WaitFor(
        id, [](const slurm::JobState& s) { return slurm::IsFinal(s.state); },
        seen);
  }

  testing::TempDir dir_;
  std::unique_ptr<SlurmCluster> cluster_;
  slurm::SlurmOptions options_;
};

// step -> path -> sha256 from the run's manifest (pipeline_state.json),
// each checked against the file on disk.
std::map<std::string, std::string> VerifiedArtifacts(const fs::path& session) {
  std::ifstream in(session / "pipeline_state.json");
  nlohmann::json state = nlohmann::json::parse(in, nullptr, false);
  EXPECT_FALSE(state.is_discarded()) << session;
  std::map<std::string, std::string> out;
  if (state.is_discarded()) return out;
  for (const auto& [step, entry] : state["steps"].items()) {
    for (const auto& a : entry["artifacts"]) {
      const std::string path = a["path"];
      absl::StatusOr<std::string> sha = io::Sha256HexOfFile(session / path);
      EXPECT_TRUE(sha.ok()) << path << ": " << sha.status();
      EXPECT_EQ(sha.value_or(""), a["sha256"]) << path;
      out[absl::StrCat(step, ":", path)] = a["sha256"];
    }
  }
  return out;
}

TEST_F(SlurmTest, SessionThroughSlurmGivesTheLocalArtifacts) {
  const fs::path local = NewSession("local");
  const fs::path remote = NewSession("remote");
  const std::vector<std::string> steps = {"stereo"};
  CommandResult r = testing::Proc(
      {"pipeline", "--session-dir", local.string(), "--steps", "stereo"});
  ASSERT_EQ(r.exit_code, 0) << r.err;

  const int64_t id = Submit(remote, steps, "1");
  std::vector<std::string> seen;
  const slurm::JobState end = WaitForEnd(id, &seen);
  EXPECT_EQ(end.state, "COMPLETED") << slurm::Describe(end);
  EXPECT_EQ(end.exit_code, "0:0");
  // The log named by --output is where scontrol says it is.
  EXPECT_EQ(end.std_out,
            (remote / "jobs/1" / absl::StrCat("slurm-", id, ".out")).string());
  EXPECT_TRUE(fs::exists(end.std_out));
  EXPECT_THAT(seen, ::testing::Contains(HasSubstr("RUNNING on node localhost")))
      << ::testing::PrintToString(seen);

  const std::map<std::string, std::string> want = VerifiedArtifacts(local);
  const std::map<std::string, std::string> got = VerifiedArtifacts(remote);
  EXPECT_GT(want.size(), 5u);
  EXPECT_EQ(got, want);
}

TEST_F(SlurmTest, FailureOnTheNodeCarriesThePipelinesMessage) {
  const fs::path local = NewSession("local");
  const fs::path remote = NewSession("remote");
  for (const fs::path& s : {local, remote}) {
    fs::remove_all(s / "captures/1/right/stereo");
  }
  CommandResult r = testing::Proc(
      {"pipeline", "--session-dir", local.string(), "--steps", "stereo"});
  ASSERT_NE(r.exit_code, 0) << "a session without its right view processed";
  std::vector<std::string> lines =
      absl::StrSplit(r.err, '\n', absl::SkipWhitespace());
  ASSERT_FALSE(lines.empty());
  const std::string message = lines.back();
  ASSERT_TRUE(absl::StartsWith(message, "hdrstereo-proc: ")) << r.err;

  const int64_t id = Submit(remote, {"stereo"}, "2");
  const slurm::JobState end = WaitForEnd(id, nullptr);
  EXPECT_EQ(end.state, "FAILED") << slurm::Describe(end);
  EXPECT_EQ(end.reason, "NonZeroExitCode");
  EXPECT_NE(end.exit_code, "0:0");
  EXPECT_THAT(testing::ReadFileOrDie(end.std_out), HasSubstr(message));
  EXPECT_FALSE(fs::exists(remote / "pipeline_state.json") &&
               VerifiedArtifacts(remote).contains("stereo"));
}

TEST_F(SlurmTest, ScancelMidRunLeavesTheJobCancelledAndUnfinished) {
  const fs::path remote = NewSession("remote");
  const int64_t id = Submit(remote, {}, "3");  // every step: long enough
  WaitFor(id, [](const slurm::JobState& s) {
    return s.state == "RUNNING" || slurm::IsFinal(s.state);
  });
  absl::StatusOr<CommandResult> c = cluster_->Run(slurm::ScancelArgv(id));
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_EQ(c->exit_code, 0) << c->err;
  const slurm::JobState end = WaitForEnd(id, nullptr);
  EXPECT_EQ(end.state, "CANCELLED") << slurm::Describe(end);
  // The run ended before its last step: no report was recorded (with an
  // early cancel, no step at all and no state file).
  bool has_report = false;
  if (!fs::exists(remote / "pipeline_state.json")) return;
  for (const auto& [key, sha] : VerifiedArtifacts(remote)) {
    has_report = has_report || absl::StartsWith(key, "report:");
  }
  EXPECT_FALSE(has_report);
}

}  // namespace
}  // namespace hdrstereo
