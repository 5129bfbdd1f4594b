// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereod with --processing-backend slurm against a real single-node
// Slurm cluster (tests/support/slurm_cluster.h): a simulated session
// processed as a batch job records the artifacts a local run records (same
// paths and sha256), `jobs cancel` scancels it and records nothing, a
// daemon restart re-attaches to the batch job, a frame missing on the
// node fails the job with the pipeline's message, a node's result naming a
// file outside the session is refused, and `hdrstereo process
// --sessions GLOB --watch` reprocesses several sessions. Skips, saying why,
// when not root or Slurm is not installed.
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
#include "tests/support/daemon_fixture.h"
#include "tests/support/slurm_cluster.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::SlurmCluster;
using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;
using ::testing::Not;

// Long enough for the small simulated session on two busy cores.
constexpr absl::Duration kJobTimeout = absl::Minutes(4);

class SlurmBackendTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  void SetUp() override {
    if (std::optional<std::string> reason = SlurmCluster::SkipReason()) {
      GTEST_SKIP() << *reason;
    }
    absl::StatusOr<std::unique_ptr<SlurmCluster>> cluster =
        SlurmCluster::Start();
    ASSERT_TRUE(cluster.ok()) << cluster.status();
    cluster_ = *std::move(cluster);
    scene_ = WriteScene("lab-lamp", SmallLabLamp());
  }

  void StartOn(const std::string& backend,
               const std::string& proc_path = HDRSTEREO_PROC,
               const std::string& max_cluster_jobs = "16") {
    StartDaemon({"--sim-scene", scene_.string(), "--processing-backend",
                 backend, "--slurm-conf", cluster_->conf().string(),
                 "--slurm-proc-path", proc_path, "--slurm-poll-s", "0.2",
                 "--slurm-cpus-per-task", "2", "--max-cluster-jobs",
                 max_cluster_jobs});
  }

  // A slow node: hdrstereo-proc starts `delay_s` after the batch job does,
  // so that a test can act while the job runs (the small session takes
  // about two seconds to process).
  std::string SlowProc(int delay_s) {
    const fs::path script = dir_ / "slow-hdrstereo-proc";
    std::ofstream(script) << "#!/bin/sh\nsleep " << delay_s << "\nexec "
                          << HDRSTEREO_PROC << " \"$@\"\n";
    fs::permissions(script, fs::perms::owner_all | fs::perms::group_read |
                                fs::perms::group_exec | fs::perms::others_read |
                                fs::perms::others_exec);
    return script.string();
  }

  // A hostile node: instead of running the pipeline it writes a result.json
  // that names `artifact_path` as an artifact of a step that succeeded.
  std::string ProcWritingAResultWith(const std::string& artifact_path) {
    using json = nlohmann::json;
    const json artifact{{"path", artifact_path}};
    const json step{{"step", "hdr"},
                    {"input_hash", "h1"},
                    {"computed", true},
                    {"artifacts", json::array({artifact})}};
    const json result{
        {"code", "OK"}, {"message", ""}, {"steps", json::array({step})}};
    const fs::path script = dir_ / "hostile-hdrstereo-proc";
    std::ofstream(script) << R"(#!/bin/sh
while [ $# -gt 0 ]; do
  if [ "$1" = --job-dir ]; then job_dir=$2; fi
  shift
done
cat > "$job_dir/result.json" <<'EOF'
)" << result.dump() << "\nEOF\n";
    fs::permissions(script, fs::perms::owner_all | fs::perms::group_read |
                                fs::perms::group_exec | fs::perms::others_read |
                                fs::perms::others_exec);
    return script.string();
  }

  void CaptureStereo(const std::string& session) {
    ASSERT_EQ(Cli({"session", "create", session}).exit_code, 0);
    CommandResult r = Cli({"capture", "stereo", session, "--watch"});
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  }

  int64_t SubmitProcessing(const std::string& session,
                           std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"process", session};
    args.insert(args.end(), extra.begin(), extra.end());
    nlohmann::json job = CliJson(args);
    const int64_t id = JsonInt(job["id"]);
    EXPECT_GT(id, 0) << job;
    return id;
  }

  std::string Events(int64_t job) {
    return Sql(absl::StrCat(
        "SELECT group_concat(message, char(10)) FROM job_events WHERE "
        "job_id = ",
        job));
  }

  // Polls the job's events until one contains `text`.
  bool WaitForEvent(int64_t job, const std::string& text) {
    const absl::Time deadline = absl::Now() + kJobTimeout;
    while (absl::Now() < deadline) {
      if (absl::StrContains(Events(job), text)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return false;
  }

  // path -> sha256 of the artifacts recorded for the session.
  std::map<std::string, std::string> Artifacts() {
    std::map<std::string, std::string> out;
    const std::string rows =
        Sql("SELECT group_concat(path || ' ' || sha256, char(10)) FROM "
            "artifacts");
    for (absl::string_view row :
         absl::StrSplit(rows, '\n', absl::SkipEmpty())) {
      std::pair<std::string, std::string> kv = absl::StrSplit(row, ' ');
      out[kv.first] = kv.second;
    }
    return out;
  }

  int64_t ClusterJobOf(int64_t job) {
    return std::stoll(Sql(absl::StrCat(
        "SELECT coalesce(cluster_job_id, 0) FROM jobs WHERE id = ", job)));
  }

  // Slurm's state of `id`, from scontrol (the fixture keeps ended jobs).
  std::string SlurmState(int64_t id) {
    absl::StatusOr<CommandResult> r =
        cluster_->Run({"scontrol", "show", "job", "-o", absl::StrCat(id)});
    if (!r.ok()) return r.status().ToString();
    for (absl::string_view word : absl::StrSplit(r->out, ' ')) {
      if (absl::ConsumePrefix(&word, "JobState=")) return std::string(word);
    }
    return r->out + r->err;
  }

  std::unique_ptr<SlurmCluster> cluster_;
  fs::path scene_;
};

TEST_F(SlurmBackendTest, ASessionProcessedOnSlurmRecordsTheLocalArtifacts) {
  StartOn("slurm");
  CaptureStereo("p");
  const int64_t job = SubmitProcessing("p");
  ASSERT_TRUE(WaitForJobState(job, "succeeded", kJobTimeout))
      << Events(job) << daemon_log();
  const int64_t slurm_job = ClusterJobOf(job);
  EXPECT_GT(slurm_job, 0) << "the Slurm job id is stored with the job";
  EXPECT_EQ(SlurmState(slurm_job), "COMPLETED");
  const std::string events = Events(job);
  EXPECT_THAT(events,
              HasSubstr(absl::StrCat("submitted to Slurm as job ", slurm_job)));
  EXPECT_THAT(events, HasSubstr(absl::StrCat("Slurm job ", slurm_job,
                                             ": RUNNING on node ")));
  EXPECT_THAT(events, HasSubstr("computed: decode, rectify, response"));
  // Each step the node computed comes with its time (for the step-time
  // metric), as in a local run: every step that recorded artifacts.
  EXPECT_EQ(
      Sql(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ", job,
                       " AND kind = 'step_computed' AND seconds >= 0")),
      Sql("SELECT count(DISTINCT step) FROM artifacts"));
  // What the operator sees of it.
  CommandResult show = Cli({"jobs", "show", std::to_string(job)});
  EXPECT_THAT(show.out, ::testing::ContainsRegex(absl::StrCat(
                            "cluster job +Slurm ", slurm_job, "\n")));
  CommandResult watch = Cli({"jobs", "watch", std::to_string(job)});
  EXPECT_EQ(watch.exit_code, 0) << watch.out;
  EXPECT_THAT(watch.out,
              ::testing::ContainsRegex(" running [0-9]+/[0-9]+ stereo: "))
      << "progress from the batch job's log";
  EXPECT_TRUE(fs::exists(data_root() / "sessions/p/jobs" / std::to_string(job) /
                         absl::StrCat("slurm-", slurm_job, ".out")))
      << "the batch job's log is in the job's folder";
  const std::map<std::string, std::string> on_slurm = Artifacts();
  ASSERT_GT(on_slurm.size(), 10u);
  EXPECT_TRUE(on_slurm.contains("report/index.html"));
  EXPECT_GT(std::stoi(Sql("SELECT count(*) FROM metrics")), 0)
      << "the evaluate step's metrics are recorded";

  // The same session processed here, forced: the same files, byte for byte.
  ASSERT_EQ(StopDaemon(), 0);
  StartOn("local");
  const int64_t local = SubmitProcessing("p", {"--force"});
  ASSERT_TRUE(WaitForJobState(local, "succeeded", kJobTimeout))
      << Events(local);
  EXPECT_EQ(ClusterJobOf(local), 0);
  const std::map<std::string, std::string> here = Artifacts();
  EXPECT_EQ(std::stoi(Sql(absl::StrCat(
                "SELECT count(*) FROM artifacts WHERE job_id = ", local))),
            static_cast<int>(here.size()))
      << "the forced local run replaced every record";
  for (const auto& [path, sha] : here) {
    ASSERT_TRUE(on_slurm.contains(path)) << path << " only from the local run";
    EXPECT_EQ(on_slurm.at(path), sha) << path;
  }
  EXPECT_EQ(here.size(), on_slurm.size());
}

TEST_F(SlurmBackendTest, CancelScancelsTheBatchJobAndRecordsNothing) {
  StartOn("slurm", SlowProc(30));
  CaptureStereo("p");
  const int64_t job = SubmitProcessing("p");
  ASSERT_TRUE(WaitForEvent(job, ": RUNNING on node")) << Events(job);
  ASSERT_EQ(Cli({"jobs", "cancel", std::to_string(job)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(job, "cancelled", absl::Seconds(90)))
      << Events(job);
  EXPECT_EQ(SlurmState(ClusterJobOf(job)), "CANCELLED");
  EXPECT_EQ(Sql("SELECT count(*) FROM artifacts"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM metrics"), "0");
}

TEST_F(SlurmBackendTest, ARestartedDaemonReattachesAndRecordsTheResults) {
  const std::string slow = SlowProc(8);
  StartOn("slurm", slow);
  CaptureStereo("p");
  const int64_t job = SubmitProcessing("p");
  ASSERT_TRUE(WaitForEvent(job, ": RUNNING on node")) << Events(job);
  const int64_t slurm_job = ClusterJobOf(job);
  ASSERT_EQ(StopDaemon(), 0);
  EXPECT_EQ(SlurmState(slurm_job), "RUNNING")
      << "stopping the daemon leaves the batch job running";

  StartOn("slurm", slow);
  ASSERT_TRUE(WaitForJobState(job, "succeeded", kJobTimeout)) << Events(job);
  EXPECT_THAT(Events(job),
              HasSubstr(absl::StrCat("re-attached to Slurm job ", slurm_job)));
  EXPECT_EQ(ClusterJobOf(job), slurm_job) << "not submitted a second time";
  EXPECT_GT(std::stoi(Sql(absl::StrCat(
                "SELECT count(*) FROM artifacts WHERE job_id = ", job))),
            10);
}

TEST_F(SlurmBackendTest, ADaemonRestartedLocalDoesNotRunABatchJobTwice) {
  StartOn("slurm", SlowProc(30));
  CaptureStereo("p");
  const int64_t job = SubmitProcessing("p");
  ASSERT_TRUE(WaitForEvent(job, ": RUNNING on node")) << Events(job);
  const int64_t slurm_job = ClusterJobOf(job);
  ASSERT_EQ(StopDaemon(), 0);

  StartOn("local");
  ASSERT_TRUE(WaitForJobState(job, "failed", absl::Seconds(60))) << Events(job);
  EXPECT_THAT(
      Sql(absl::StrCat("SELECT error FROM jobs WHERE id = ", job)),
      HasSubstr(absl::StrCat("was submitted to Slurm as job ", slurm_job,
                             " and this daemon runs processing "
                             "locally")));
  EXPECT_EQ(Sql("SELECT count(*) FROM artifacts"), "0");
  absl::StatusOr<CommandResult> cancel =
      cluster_->Run({"scancel", std::to_string(slurm_job)});
  ASSERT_TRUE(cancel.ok()) << cancel.status();
}

TEST_F(SlurmBackendTest, AFrameMissingOnTheNodeFailsWithThePipelinesMessage) {
  StartOn("slurm");
  CaptureStereo("p");
  const std::string frame = Sql("SELECT path FROM frames ORDER BY id LIMIT 1");
  ASSERT_TRUE(fs::remove(data_root() / "sessions/p" / frame)) << frame;
  const int64_t job = SubmitProcessing("p");
  ASSERT_TRUE(WaitForJobState(job, "failed", kJobTimeout)) << Events(job);
  const std::string error =
      Sql(absl::StrCat("SELECT error FROM jobs WHERE id = ", job));
  EXPECT_THAT(error, HasSubstr(absl::StrCat("frame ", frame, " is missing")));
  EXPECT_EQ(SlurmState(ClusterJobOf(job)), "FAILED");
  EXPECT_EQ(Sql("SELECT count(*) FROM artifacts"), "0");
}

// A node's result naming a file outside the session is refused, says so
// (not "without a result"), and nothing of it is recorded.
TEST_F(SlurmBackendTest, AResultNamingAPathOutsideTheSessionIsRefused) {
  StartOn("slurm", ProcWritingAResultWith("../../etc/passwd"));
  CaptureStereo("p");
  const int64_t job = SubmitProcessing("p");
  ASSERT_TRUE(WaitForJobState(job, "failed", kJobTimeout)) << Events(job);
  const int64_t slurm_job = ClusterJobOf(job);
  EXPECT_EQ(SlurmState(slurm_job), "COMPLETED");
  const std::string error =
      Sql(absl::StrCat("SELECT error FROM jobs WHERE id = ", job));
  EXPECT_THAT(error, HasSubstr(absl::StrCat(
                         "Slurm job ", slurm_job,
                         " ended COMPLETED; its result was refused: ")));
  EXPECT_THAT(error,
              HasSubstr(absl::StrCat(
                  "/jobs/", job,
                  "/result.json: not a pipeline job result: "
                  "steps[0].artifacts[0].path: path \"../../etc/passwd\" "
                  "has a \"..\" component")));
  EXPECT_THAT(error, Not(HasSubstr("without a result")));
  EXPECT_EQ(Sql("SELECT count(*) FROM artifacts"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM metrics"), "0");
}

TEST_F(SlurmBackendTest, BatchReprocessingOfFourSessionsFromTheCli) {
  StartOn("slurm", HDRSTEREO_PROC, "2");
  for (const char* s : {"night-1", "night-2", "night-3", "night-4"}) {
    CaptureStereo(s);
  }
  CaptureStereo("day-1");
  ASSERT_EQ(Cli({"session", "create", "night-5"}).exit_code, 0);
  // "night-*" matches five sessions, not day-1; night-5 has nothing to
  // process and is skipped, saying why.
  CommandResult r = Cli({"process", "--sessions", "night-*", "--steps",
                         "stereo,fusion", "--watch"},
                        kJobTimeout);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err << daemon_log();
  for (const char* s : {"night-1", "night-2", "night-3", "night-4"}) {
    EXPECT_THAT(r.out, HasSubstr(absl::StrCat("processing session ", s)));
    EXPECT_THAT(r.out, ::testing::ContainsRegex(
                           absl::StrCat(s, " +job [0-9]+ +succeeded")));
  }
  EXPECT_THAT(r.out, HasSubstr("total: 4 sessions, 4 succeeded, 0 failed"));
  EXPECT_THAT(r.err, HasSubstr("skipped night-5: session \"night-5\" has no "
                               "bracketed-stereo capture"));
  EXPECT_THAT(r.out, Not(HasSubstr("day-1")));
  EXPECT_EQ(Sql("SELECT count(DISTINCT cluster_job_id) FROM jobs WHERE kind = "
                "'processing' AND state = 'succeeded'"),
            "4")
      << "one batch job each";
}

}  // namespace
}  // namespace hdrstereo
