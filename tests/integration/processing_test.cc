// SPDX-License-Identifier: GPL-3.0-or-later
//
// Processing jobs end to end: the real daemon with simulated hardware, real
// SQLite, gRPC and CLI. A session is captured (bracketed stereo and
// structured light of the bundled lab-lamp scene at a small size), processed
// by the pipeline, and what it produced is checked against the database, the
// files and the simulator's exact truth.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "processing/io/sha256.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/subprocess.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;
using ::testing::Not;

class ProcessingTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  void StartSim(nlohmann::json patch = SmallLabLamp()) {
    StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  }

  void Capture(const std::string& session, const std::string& kind) {
    CommandResult r = Cli({"capture", kind, session, "--watch"});
    ASSERT_EQ(r.exit_code, 0) << r.out;
  }

  fs::path SessionDir(const std::string& session) const {
    return data_root() / "sessions" / session;
  }

  // Runs `process` and returns the job's "computed: ...; reused: ..." line.
  std::string Process(const std::string& session,
                      std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"process", session};
    args.insert(args.end(), extra.begin(), extra.end());
    nlohmann::json job = CliJson(args);
    const int64_t id = JsonInt(job["id"]);
    EXPECT_GT(id, 0) << job;
    EXPECT_TRUE(WaitForJobState(id, "succeeded")) << daemon_log();
    return Sql(absl::StrCat("SELECT message FROM job_events WHERE job_id = ",
                            id, " AND message LIKE 'computed:%'"));
  }

  std::map<std::string, double> Rmse(const std::string& session,
                                     const std::string& ground_truth) {
    std::map<std::string, double> out;
    const std::string rows = Sql(absl::StrCat(
        "SELECT group_concat(m.method || '=' || m.rmse, ';') FROM metrics m "
        "JOIN sessions s ON s.id = m.session_id WHERE s.name = '",
        session, "' AND m.ground_truth = '", ground_truth, "'"));
    for (absl::string_view row : absl::StrSplit(rows, ';', absl::SkipEmpty())) {
      std::pair<std::string, std::string> kv = absl::StrSplit(row, '=');
      out[kv.first] = std::stod(kv.second);
    }
    return out;
  }
};

TEST_F(ProcessingTest, CaptureProcessArtifactsMetricsAndReuse) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "p"}).exit_code, 0);
  Capture("p", "stereo");
  Capture("p", "sl");
  EXPECT_TRUE(fs::exists(SessionDir("p") / "captures/1/truth/disp0.pfm"))
      << "a simulated stereo capture carries its exact truth";

  CommandResult run = Cli({"process", "p", "--watch"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err << daemon_log();
  EXPECT_THAT(run.out, HasSubstr("METHOD")) << "the metrics table is printed";

  // Every artifact row names an existing file with its sha256; the kinds the
  // pipeline promises are there.
  nlohmann::json artifacts = CliJson({"artifacts", "p"});
  ASSERT_TRUE(artifacts.contains("artifacts")) << artifacts;
  std::set<std::string> kinds;
  std::set<std::string> paths;
  for (const nlohmann::json& a : artifacts["artifacts"]) {
    const fs::path file = SessionDir("p") / a["path"].get<std::string>();
    absl::StatusOr<std::string> sha = io::Sha256HexOfFile(file);
    ASSERT_TRUE(sha.ok()) << file << " is missing";
    EXPECT_EQ(*sha, a["sha256"].get<std::string>()) << file;
    kinds.insert(a["kind"].get<std::string>());
    paths.insert(a["path"].get<std::string>());
  }
  EXPECT_EQ(Sql("SELECT count(*) FROM artifacts"),
            std::to_string(artifacts["artifacts"].size()));
  for (const char* kind : {"hdr", "tonemapped", "disparity", "report"}) {
    EXPECT_TRUE(kinds.contains(kind)) << "no artifact of kind " << kind;
  }
  for (const char* path : {"im0.png", "im1.png", "disp0GT.pfm", "mask0nocc.png",
                           "calib.txt", "report/index.html"}) {
    EXPECT_TRUE(paths.contains(path)) << path << " is not an artifact";
  }

  // Metrics against both truths; the thesis' claim on the exact truth.
  std::map<std::string, double> sim = Rmse("p", "simulation");
  ASSERT_TRUE(sim.contains("ldr") && sim.contains("fused"))
      << Sql("SELECT method, ground_truth, rmse FROM metrics");
  EXPECT_LT(sim["fused"], sim["ldr"]);
  EXPECT_FALSE(Rmse("p", "structured_light").empty());
  // The structured-light ground truth is itself scored against the exact
  // truth (its row is not a method: never "worse than LDR").
  ASSERT_TRUE(sim.contains("structured_light"))
      << Sql("SELECT method, ground_truth, rmse FROM metrics");
  EXPECT_LT(sim["structured_light"], 1.0) << "the SL ground truth is sub-pixel";
  CommandResult metrics = Cli({"metrics", "p"});
  EXPECT_EQ(metrics.exit_code, 0);
  EXPECT_THAT(metrics.out, HasSubstr("fused"));
  // The table is led by the ground truth's quality and the best methods.
  EXPECT_THAT(metrics.out,
              HasSubstr("structured-light ground truth, against the "
                        "simulator's exact truth: covers "));
  EXPECT_THAT(metrics.out, HasSubstr("against simulation: best by RMSE "));
  EXPECT_LT(metrics.out.find("structured-light ground truth"),
            metrics.out.find("GROUND TRUTH"));
  // worse_than_ldr is exactly "RMSE above LDR's against the same truth",
  // and every such method is named in the line that says so.
  nlohmann::json listed = CliJson({"metrics", "p"});
  std::map<std::string, double> ldr;
  for (const nlohmann::json& m : listed["metrics"]) {
    if (m["method"] == "ldr") ldr[m["ground_truth"]] = m["rmse_px"];
  }
  int worse = 0;
  for (const nlohmann::json& m : listed["metrics"]) {
    const std::string method = m["method"];
    const bool expected = method != "ldr" && method != "structured_light" &&
                          m["rmse_px"].get<double>() > ldr[m["ground_truth"]];
    EXPECT_EQ(m["worse_than_ldr"].get<bool>(), expected) << m;
    if (!expected) continue;
    ++worse;
    const std::string line =
        absl::StrCat("against ", m["ground_truth"].get<std::string>(),
                     ", worse than LDR by RMSE: ");
    const size_t at = metrics.out.find(line);
    ASSERT_NE(at, std::string::npos) << metrics.out;
    EXPECT_NE(metrics.out.find(method + " (", at), std::string::npos)
        << method << " not named: " << metrics.out;
  }
  std::cout << metrics.out << worse << " method rows worse than LDR\n";

  CommandResult report = Cli({"report", "p", "--open"});
  EXPECT_EQ(report.exit_code, 0) << report.out;
  EXPECT_THAT(report.out, HasSubstr("file://"));
  EXPECT_THAT(report.out, HasSubstr("report/index.html"));
  // The daemon's report renders in headless Chromium with every image.
  ASSERT_TRUE(fs::exists("/usr/bin/chromium"))
      << "chromium missing: run deploy/setup-deps.sh";
  absl::StatusOr<CommandResult> dom = ::hdrstereo::testing::RunCommand(
      {"/usr/bin/chromium", "--headless", "--no-sandbox", "--disable-gpu",
       "--disable-dev-shm-usage", "--no-first-run",
       absl::StrCat("--user-data-dir=", (dir_ / "chromium").string()),
       "--virtual-time-budget=10000", "--dump-dom",
       absl::StrCat("file://",
                    (SessionDir("p") / "report/index.html").string())},
      absl::Seconds(120));
  ASSERT_TRUE(dom.ok()) << dom.status();
  const size_t loaded = dom->out.find("data-images-loaded=\"");
  ASSERT_NE(loaded, std::string::npos) << dom->err;
  const std::string counts = dom->out.substr(
      loaded + 20, dom->out.find('"', loaded + 20) - loaded - 20);
  const std::pair<std::string, std::string> ratio = absl::StrSplit(counts, '/');
  EXPECT_EQ(ratio.first, ratio.second) << "images that did not load";
  EXPECT_GT(std::stoi(ratio.second), 20);
  EXPECT_THAT(dom->out, HasSubstr("<table id=\"metrics\">"));
  EXPECT_THAT(dom->out, HasSubstr("<th>vs LDR</th>"));
  if (worse > 0) {
    EXPECT_THAT(dom->out, HasSubstr("worse than LDR"));
  }

  // Unchanged inputs: nothing is recomputed, no file is rewritten.
  const std::string kTimes =
      "SELECT group_concat(t) FROM (SELECT create_time_ms t FROM artifacts "
      "ORDER BY id)";
  const std::string times = Sql(kTimes);
  EXPECT_THAT(Process("p"), HasSubstr("computed: nothing"));
  EXPECT_EQ(Sql(kTimes), times);

  // A deleted file: only its step runs again (its output is the same, so
  // what depends on it is reused).
  const std::string tonemapped =
      Sql("SELECT path FROM artifacts WHERE step = 'tonemap' LIMIT 1");
  ASSERT_FALSE(tonemapped.empty());
  fs::remove(SessionDir("p") / tonemapped);
  const std::string again = Process("p");
  const std::string computed = again.substr(0, again.find(';'));
  EXPECT_THAT(computed, HasSubstr("tonemap")) << again;
  for (const char* step : {"decode", "hdr", "sl_groundtruth", "stereo"}) {
    EXPECT_THAT(computed, Not(HasSubstr(step)))
        << step << " was recomputed: " << again;
  }
  EXPECT_TRUE(fs::exists(SessionDir("p") / tonemapped));

  // --force recomputes every step.
  EXPECT_THAT(Process("p", {"--force"}), HasSubstr("reused: nothing"));
}

TEST_F(ProcessingTest, DownloadIsResumableAndChecked) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "d"}).exit_code, 0);
  Capture("d", "stereo");
  ASSERT_EQ(Cli({"process", "d", "--steps", "hdr", "--watch"}).exit_code, 0)
      << daemon_log();
  nlohmann::json listed = CliJson({"artifacts", "d", "--kind", "hdr"});
  ASSERT_FALSE(listed["artifacts"].empty()) << listed;
  const nlohmann::json& artifact = listed["artifacts"][0];
  const std::string path = artifact["path"].get<std::string>();
  const std::string bytes =
      ::hdrstereo::testing::ReadFileOrDie(SessionDir("d") / path);
  ASSERT_GT(bytes.size(), 16u);

  // An interrupted download (half the bytes in .part) is continued.
  const fs::path to = dir_ / "download";
  fs::create_directories((to / path).parent_path());
  {
    std::ofstream part(to / (path + ".part"), std::ios::binary);
    part << bytes.substr(0, bytes.size() / 2);
  }
  CommandResult fetched =
      Cli({"download", "d", "--kind", "hdr", "--to", to.string()});
  ASSERT_EQ(fetched.exit_code, 0) << fetched.out;
  EXPECT_EQ(::hdrstereo::testing::ReadFileOrDie(to / path), bytes);
  EXPECT_FALSE(fs::exists(to / (path + ".part")));

  // A .part that does not match the server's file is caught by the sha256.
  fs::remove(to / path);
  {
    std::ofstream part(to / (path + ".part"), std::ios::binary);
    part << std::string(bytes.size() / 2, 'x');
  }
  CommandResult bad =
      Cli({"download", "d", "--kind", "hdr", "--to", to.string()});
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.err, HasSubstr("sha256"));
  EXPECT_FALSE(fs::exists(to / path));
  EXPECT_EQ(
      Cli({"download", "d", "--kind", "hdr", "--to", to.string()}).exit_code,
      0);
  EXPECT_EQ(::hdrstereo::testing::ReadFileOrDie(to / path), bytes);
}

// A job that would need more memory than a processing job may use is
// refused before anything is queued, naming how much it needs, for which
// steps and frames, and the budget with where it comes from. (Every other
// test here processes within the default budget: this machine's memory
// shared by the processing threads.)
TEST_F(ProcessingTest, AJobThatCannotFitInMemoryIsRefusedNamingItsNeed) {
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", SmallLabLamp()).string(),
               "--processing-memory", "100M"});
  ASSERT_EQ(Cli({"session", "create", "m"}).exit_code, 0);
  Capture("m", "stereo");
  CommandResult refused = Cli({"process", "m"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_THAT(refused.err, HasSubstr("processing session m would need about"));
  EXPECT_THAT(refused.err, HasSubstr("8 exposures a view"));
  EXPECT_THAT(refused.err,
              HasSubstr("more than the 100 MiB a processing job may use "
                        "(--processing-memory 100M)"));
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs WHERE kind = 'processing'"), "0");
}

// Queued behind a capture that is still running, a job is checked when it
// starts: it fails before any step runs, with the same message, and the
// capture is not disturbed.
TEST_F(ProcessingTest, AJobQueuedBehindACaptureIsCheckedWhenItStarts) {
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", SmallLabLamp()).string(),
               "--processing-memory", "100M", "--sim-time-scale", "0.2"});
  ASSERT_EQ(Cli({"session", "create", "q"}).exit_code, 0);
  const int64_t capture = Submit({"capture", "stereo", "q"});
  ASSERT_GT(capture, 0);
  const int64_t job = Submit({"process", "q"});
  ASSERT_GT(job, 0) << "queued: its input is still being captured";
  ASSERT_TRUE(WaitForJobState(job, "failed")) << Job(job).dump(2);
  EXPECT_THAT(Sql(absl::StrCat("SELECT error FROM jobs WHERE id = ", job)),
              HasSubstr("processing session q would need about"));
  EXPECT_TRUE(WaitForJobState(capture, "succeeded")) << Job(capture).dump(2);
  EXPECT_EQ(Sql("SELECT count(*) FROM artifacts"), "0");
}

TEST_F(ProcessingTest, BadRequestsNameWhatIsMissingAndDeleteNothing) {
  const std::string kArtifactRows =
      "SELECT group_concat(r) FROM (SELECT path || ':' || sha256 r FROM "
      "artifacts ORDER BY id)";
  nlohmann::json patch = SmallLabLamp();
  // The stereo capture takes 17 frames; the structured-light one fails at
  // its 8th, which times out at each of its three attempts.
  patch["faults"] = {{"camera", {{"timeout", {{"calls", {25, 26, 27}}}}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "empty"}).exit_code, 0);
  CommandResult nothing = Cli({"process", "empty"});
  EXPECT_EQ(nothing.exit_code, 1);
  EXPECT_THAT(nothing.err, HasSubstr("no bracketed-stereo capture"));

  CommandResult unknown = Cli({"process", "empty", "--steps", "hdr,fuzion"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_THAT(unknown.err, HasSubstr("fuzion"));
  EXPECT_EQ(Cli({"process", "nosuch"}).exit_code, 4);
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs"), "0") << "nothing was queued";

  ASSERT_EQ(Cli({"session", "create", "s"}).exit_code, 0);
  Capture("s", "stereo");
  ASSERT_EQ(Cli({"process", "s", "--steps", "hdr", "--watch"}).exit_code, 0);
  const std::string hdr_rows = Sql(kArtifactRows);
  ASSERT_FALSE(hdr_rows.empty());
  EXPECT_NE(Cli({"capture", "sl", "s", "--watch"}).exit_code, 0)
      << "the injected camera timeout fails the structured-light capture";

  CommandResult incomplete = Cli({"process", "s"});
  EXPECT_EQ(incomplete.exit_code, 1);
  EXPECT_THAT(incomplete.err, HasSubstr("structured-light capture 2"));
  EXPECT_THAT(incomplete.err, HasSubstr("incomplete"));
  EXPECT_THAT(incomplete.err, HasSubstr("structured_light/sl_"));
  // Steps that do not need it still run; nothing computed was deleted.
  EXPECT_EQ(Sql(kArtifactRows), hdr_rows);
  for (absl::string_view row :
       absl::StrSplit(hdr_rows, ',', absl::SkipEmpty())) {
    std::pair<std::string, std::string> kv = absl::StrSplit(row, ':');
    EXPECT_TRUE(fs::exists(SessionDir("s") / kv.first)) << kv.first;
  }
}

}  // namespace
}  // namespace hdrstereo
