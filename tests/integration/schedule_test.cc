// SPDX-License-Identifier: GPL-3.0-or-later
//
// Schedules end to end: the real daemon on sim hardware runs a schedule that
// comes due, and the CLI refuses bad schedules with the offending token.
// The daemon's scheduler clock runs 60x (--scheduler-clock-rate, test only),
// so "* * * * *" is due within about a second of real time.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <fstream>
#include <set>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "tests/support/daemon_fixture.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;

class ScheduleTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  void StartSim(double clock_rate = 1) {
    StartDaemon({"--sim-scene", WriteScene("lab-lamp", SmallLabLamp()).string(),
                 "--scheduler-clock-rate", absl::StrCat(clock_rate)});
  }

  std::string WritePlan(const std::string& json) {
    const std::filesystem::path path =
        dir_ / absl::StrCat("plan", ++plans_, ".json");
    std::ofstream(path) << json;
    return path.string();
  }

  int plans_ = 0;
};

constexpr char kPlan[] = R"({
  "sessionPattern": "e2e-{date}-{time}",
  "captures": [{"bracketedStereo": {"exposuresS": [0.01, 0.004]}}],
  "processingSteps": ["hdr"]
})";

TEST_F(ScheduleTest, ScheduleDueNowCapturesTheSession) {
  StartSim(/*clock_rate=*/60);
  testing::CommandResult add =
      Cli({"schedule", "add", "e2e", "--cron", "* * * * *", "--plan",
           WritePlan(kPlan), "--tz", "Europe/Berlin"});
  ASSERT_EQ(add.exit_code, 0) << add.err;
  EXPECT_THAT(add.out, HasSubstr("next due"));

  // Poll the run history until a run succeeded (at most 120 s).
  nlohmann::json succeeded;
  for (int i = 0; i < 600 && succeeded.is_null(); ++i) {
    nlohmann::json runs = CliJson({"schedule", "runs", "e2e"});
    for (const nlohmann::json& run :
         runs.value("runs", nlohmann::json::array())) {
      if (run.value("outcome", "") == "OUTCOME_SUCCEEDED") succeeded = run;
    }
    if (succeeded.is_null()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
  ASSERT_FALSE(succeeded.is_null()) << daemon_log();
  ASSERT_EQ(Cli({"schedule", "disable", "e2e"}).exit_code, 0);

  const std::string session = succeeded["session"];
  EXPECT_THAT(session, ::testing::StartsWith("e2e-"));
  // The capture, then the processing job that waited for it.
  ASSERT_EQ(succeeded["job_ids"].size(), 2u);
  EXPECT_EQ(
      CliJson({"jobs", "show", succeeded["job_ids"][1].get<std::string>()})
          .value("kind", ""),
      "JOB_KIND_PROCESSING");
  // The session holds the capture: one ambient frame + 2 views x 2
  // exposures.
  EXPECT_EQ(Sql("SELECT count(*) FROM frames f JOIN captures c ON "
                "c.id = f.capture_id JOIN sessions s ON s.id = c.session_id "
                "WHERE s.name = '" +
                session + "'"),
            "5");
  nlohmann::json shown = CliJson({"session", "show", session});
  EXPECT_EQ(shown.value("frame_count", 0), 5);
  EXPECT_THAT(shown.value("note", ""), HasSubstr("scheduled by e2e"));
  // ... and what processing made of it: the HDR radiance of both views.
  nlohmann::json hdr = CliJson({"artifacts", session, "--kind", "hdr"});
  std::set<std::string> paths;
  for (const nlohmann::json& a :
       hdr.value("artifacts", nlohmann::json::array())) {
    paths.insert(a.value("path", ""));
  }
  EXPECT_TRUE(paths.contains("hdr/im0.pfm") && paths.contains("hdr/im1.pfm"))
      << hdr;

  // `schedule list` shows it disabled; runs are listed; delete removes it.
  testing::CommandResult list = Cli({"schedule", "list"});
  EXPECT_THAT(list.out, HasSubstr("e2e"));
  EXPECT_THAT(list.out, HasSubstr("(disabled)"));
  testing::CommandResult runs = Cli({"schedule", "runs", "e2e"});
  EXPECT_THAT(runs.out, HasSubstr(session));
  ASSERT_EQ(Cli({"schedule", "delete", "e2e"}).exit_code, 0);
  EXPECT_EQ(Cli({"schedule", "runs", "e2e"}).exit_code, 4);
  EXPECT_EQ(Sql("SELECT count(*) FROM schedule_runs"), "0");
}

TEST_F(ScheduleTest, BadSchedulesAreRefusedNamingTheProblem) {
  StartSim();
  const std::string plan = WritePlan(kPlan);
  struct Bad {
    std::vector<std::string> args;
    const char* says;
  };
  const std::vector<Bad> bad = {
      {{"--cron", "0 25 * * *", "--plan", plan}, "hour field: \"25\""},
      {{"--cron", "0 2 * * FUNDAY", "--plan", plan},
       "day-of-week field: \"FUNDAY\""},
      {{"--cron", "0 0 30 2 *", "--plan", plan}, "never due"},
      {{"--cron", "0 2 * * *", "--tz", "Mars/Olympus", "--plan", plan},
       "Mars/Olympus"},
      {{"--cron", "0 2 * * *", "--plan",
        WritePlan(R"({"sessionPattern": "n-{date}", "captures": [)"
                  R"({"bracketedStereo": {"exposuresS": [-1]}}]})")},
       "plan.captures[0]"},
      {{"--cron", "0 2 * * *", "--plan",
        WritePlan(R"({"sessionPattern": "n-{date}", "captures": [)"
                  R"({"bracketedStereo": {}}], "processingSteps": ["hdrr"]})")},
       "plan.processing_steps: unknown step \"hdrr\""},
      {{"--cron", "0 2 * * *", "--plan",
        WritePlan(R"({"sessionPattern": "n-{week}", "captures": [)"
                  R"({"bracketedStereo": {}}]})")},
       "{week}"},
  };
  for (const Bad& b : bad) {
    std::vector<std::string> args = {"schedule", "add", "nightly"};
    args.insert(args.end(), b.args.begin(), b.args.end());
    testing::CommandResult r = Cli(args);
    EXPECT_EQ(r.exit_code, 2) << b.says << ": " << r.out;
    EXPECT_THAT(r.err, HasSubstr(b.says));
  }
  // Unknown plan fields are refused by the CLI, naming the field.
  testing::CommandResult unknown =
      Cli({"schedule", "add", "nightly", "--cron", "0 2 * * *", "--plan",
           WritePlan(R"({"sessionPattern": "n", "captrues": []})")});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_THAT(unknown.err, HasSubstr("captrues"));
  // Bad name.
  EXPECT_THAT(Cli({"schedule", "add", "no/slash", "--cron", "0 2 * * *",
                   "--plan", plan})
                  .err,
              HasSubstr("schedule.name"));
  // Nothing was stored.
  EXPECT_EQ(Sql("SELECT count(*) FROM schedules"), "0");
}

// systemd's ExecReload sends SIGHUP: the daemon re-reads its configuration
// and keeps serving (it must not die of the signal).
TEST_F(ScheduleTest, SighupReloadsAndKeepsServing) {
  StartSim();
  daemon_->Signal(SIGHUP);
  bool logged = false;
  for (int i = 0; i < 100 && !logged; ++i) {
    logged = daemon_log().find("reload: log level info") != std::string::npos;
    if (!logged) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(logged) << daemon_log();
  EXPECT_EQ(Cli({"status"}).exit_code, 0);
  EXPECT_EQ(StopDaemon(), 0);
}

}  // namespace
}  // namespace hdrstereo
