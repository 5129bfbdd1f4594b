// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Slurm output parsers on outputs recorded from Debian 12's Slurm 22.05
// (the single-node cluster of tests/support/slurm_cluster.h): testdata/.
#include "daemon/processing/slurm_cli.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::slurm {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::string Recorded(const std::string& name) {
  std::ifstream in(std::string(HDRSTEREO_SOURCE_DIR) +
                   "/tests/unit/slurm/testdata/" + name);
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_FALSE(s.str().empty()) << name;
  return s.str();
}

TEST(SlurmCliTest, ParsesSbatchParsable) {
  absl::StatusOr<int64_t> id =
      ParseSbatchOutput(Recorded("sbatch_parsable.txt"));
  ASSERT_TRUE(id.ok()) << id.status();
  EXPECT_EQ(*id, 4);
  absl::StatusOr<int64_t> federated = ParseSbatchOutput("812;cluster2\n");
  ASSERT_TRUE(federated.ok()) << federated.status();
  EXPECT_EQ(*federated, 812);
  EXPECT_THAT(ParseSbatchOutput("sbatch: error: invalid partition"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("invalid partition")));
}

TEST(SlurmCliTest, ParsesSqueueLines) {
  const std::string out = Recorded("squeue.txt");
  absl::StatusOr<JobState> pending = ParseSqueueOutput(out, 5);
  ASSERT_TRUE(pending.ok()) << pending.status();
  EXPECT_EQ(pending->state, "PENDING");
  EXPECT_EQ(pending->reason, "Resources");
  EXPECT_EQ(Describe(*pending), "PENDING (Resources)");
  absl::StatusOr<JobState> running = ParseSqueueOutput(out, 4);
  ASSERT_TRUE(running.ok()) << running.status();
  EXPECT_EQ(Describe(*running), "RUNNING on node localhost");
  EXPECT_THAT(ParseSqueueOutput(out, 6),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("job 6")));
  EXPECT_THAT(ParseSqueueOutput("", 6), StatusIs(absl::StatusCode::kNotFound));
  EXPECT_THAT(
      ParseSqueueOutput("4 RUNNING None localhost\n", 4),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("4 fields")));
}

TEST(SlurmCliTest, ParsesScontrolStates) {
  struct Case {
    std::string file;
    int64_t id;
    std::string state, reason, exit_code, described;
  };
  for (const Case& c : {
           Case{"scontrol_pending.txt", 5, "PENDING", "Resources", "0:0",
                "PENDING (Resources)"},
           Case{"scontrol_running.txt", 4, "RUNNING", "None", "0:0",
                "RUNNING on node localhost"},
           Case{"scontrol_completed.txt", 2, "COMPLETED", "None", "0:0",
                "COMPLETED"},
           Case{"scontrol_failed.txt", 3, "FAILED", "NonZeroExitCode", "3:0",
                "FAILED (NonZeroExitCode, exit 3:0)"},
           Case{"scontrol_cancelled.txt", 1, "CANCELLED", "None", "0:15",
                "CANCELLED (exit 0:15)"},
       }) {
    absl::StatusOr<JobState> s = ParseScontrolOutput(Recorded(c.file), c.id);
    ASSERT_TRUE(s.ok()) << c.file << ": " << s.status();
    EXPECT_EQ(s->state, c.state) << c.file;
    EXPECT_EQ(s->reason, c.reason) << c.file;
    EXPECT_EQ(s->exit_code, c.exit_code) << c.file;
    EXPECT_EQ(Describe(*s), c.described) << c.file;
    EXPECT_EQ(IsFinal(s->state), c.state != "PENDING" && c.state != "RUNNING")
        << c.file;
  }
  absl::StatusOr<JobState> failed =
      ParseScontrolOutput(Recorded("scontrol_failed.txt"), 3);
  ASSERT_TRUE(failed.ok());
  EXPECT_EQ(failed->std_out, "/tmp/slurm-rec23/out-3.txt");
  EXPECT_THAT(
      ParseScontrolOutput(Recorded("scontrol_failed.txt"), 4),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("show job 4")));
  EXPECT_THAT(
      ParseScontrolOutput("slurm_load_jobs error: Invalid job id specified", 9),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("Invalid job id")));
}

TEST(SlurmCliTest, ParsesSacctsParsableRecord) {
  EXPECT_THAT(SacctArgv(77),
              ElementsAre("sacct", "-n", "-P", "-X", "-j", "77", "-o",
                          "JobID,State,ExitCode,NodeList,Reason"));
  // As Slurm 22.05 prints them: a job cancelled by root, then others.
  const std::string out =
      "76|COMPLETED|0:0|c07|None\n"
      "77|CANCELLED by 0|0:15|c12|None\n";
  ASSERT_OK_AND_ASSIGN(JobState cancelled, ParseSacctOutput(out, 77));
  EXPECT_EQ(cancelled.state, "CANCELLED by 0");
  EXPECT_TRUE(IsFinal(cancelled.state));
  EXPECT_EQ(cancelled.exit_code, "0:15");
  EXPECT_EQ(cancelled.nodes, "c12");
  EXPECT_EQ(Describe(cancelled), "CANCELLED by 0 (exit 0:15)");
  ASSERT_OK_AND_ASSIGN(JobState timeout,
                       ParseSacctOutput("80|TIMEOUT|0:0|c01|TimeLimit\n", 80));
  EXPECT_EQ(Describe(timeout), "TIMEOUT (TimeLimit)");
  EXPECT_THAT(ParseSacctOutput("", 77),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("job 77")));
  EXPECT_THAT(ParseSacctOutput("77|FAILED|1:0\n", 77),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("does not have 5 fields")));
}

// Job ids as Slurm has them (32 bits); ids that overflow or are out of
// range are refused by name.
TEST(SlurmCliTest, SbatchJobIdsAreBounded) {
  ASSERT_OK_AND_ASSIGN(int64_t largest, ParseSbatchOutput("4294967295\n"));
  EXPECT_EQ(largest, kMaxJobId);
  for (const char* out : {"4294967296", "0", "-3;cluster"}) {
    EXPECT_THAT(ParseSbatchOutput(out),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("sbatch job id: ")))
        << out;
  }
  EXPECT_THAT(ParseSbatchOutput("4294967296"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("sbatch job id: 4294967296 is outside [1, "
                                 "4294967295]")));
  EXPECT_THAT(ParseSbatchOutput("99999999999999999999999"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("sbatch printed no job id: "
                                 "\"99999999999999999999999\"")));
}

// Output beyond kMaxOutputBytes, fields beyond kMaxFieldBytes, and long
// garbage quoted as a bounded prefix.
TEST(SlurmCliTest, OutputAndFieldsAreBounded) {
  const std::string huge(kMaxOutputBytes + 1, '\n');
  EXPECT_THAT(ParseSbatchOutput(huge),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("sbatch printed 1048577 bytes; the most is "
                                 "1048576")));
  EXPECT_THAT(ParseSqueueOutput(huge, 4),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("squeue printed 1048577 bytes")));
  EXPECT_THAT(ParseScontrolOutput(huge, 4),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("scontrol printed 1048577 bytes")));
  EXPECT_THAT(ParseSacctOutput(huge, 4),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("sacct printed 1048577 bytes")));

  // Many other jobs' lines before this one's, within the limit.
  std::string lines;
  for (int i = 0; i < 50000; ++i) absl::StrAppend(&lines, i, "|R|r|n\n");
  ASSERT_OK_AND_ASSIGN(
      JobState found,
      ParseSqueueOutput(lines + "77777|RUNNING|None|c1\n", 77777));
  EXPECT_EQ(found.nodes, "c1");

  const std::string longest(kMaxFieldBytes, 'N');
  ASSERT_OK_AND_ASSIGN(JobState at_limit,
                       ParseSqueueOutput("4|PENDING|" + longest + "|\n", 4));
  EXPECT_EQ(at_limit.reason, longest);
  absl::StatusOr<JobState> reason =
      ParseSqueueOutput("4|PENDING|" + longest + "N|\n", 4);
  EXPECT_THAT(reason, StatusIs(absl::StatusCode::kInvalidArgument,
                               HasSubstr("squeue printed a reason of 4097 "
                                         "bytes: \"NNN")));
  EXPECT_THAT(reason, StatusIs(absl::StatusCode::kInvalidArgument,
                               HasSubstr("\"... (4097 bytes); the most is "
                                         "4096")));
  EXPECT_LT(reason.status().message().size(), 200u);
  EXPECT_THAT(
      ParseScontrolOutput("JobId=4 JobState=RUNNING StdOut=/" + longest, 4),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("scontrol printed a log path of 4097 bytes")));
  EXPECT_THAT(ParseSacctOutput("4|FAILED|1:0|" + longest + "x|None\n", 4),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("sacct printed a node list of 4097 bytes")));

  const std::string garbage(10000, '\x07');
  absl::StatusOr<JobState> squeue = ParseSqueueOutput(garbage, 4);
  EXPECT_THAT(squeue, StatusIs(absl::StatusCode::kInvalidArgument,
                               HasSubstr("\\x07\"... (10000 bytes) does not "
                                         "have 4 fields")));
  EXPECT_LT(squeue.status().message().size(), 400u);
  absl::StatusOr<JobState> scontrol = ParseScontrolOutput(garbage, 4);
  EXPECT_THAT(scontrol, StatusIs(absl::StatusCode::kInvalidArgument,
                                 HasSubstr("printed no JobId/JobState")));
  EXPECT_LT(scontrol.status().message().size(), 400u);
  EXPECT_THAT(ParseSacctOutput(std::string(20000, '|'), 4),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("(20000 bytes) does not have 5 fields")));
}

// Found by slurm_output_fuzzer: a job's line with an empty state was a job
// state Describe() could not say anything about (and never final).
TEST(SlurmCliTest, ALineWithoutAStateIsRefused) {
  EXPECT_THAT(ParseSacctOutput("4||0:0|c1|None\n", 4),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("sacct printed no state for job 4")));
  EXPECT_THAT(ParseSqueueOutput("4||None|\n", 4),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("squeue printed no state for job 4")));
  // The fuzzer's input, as it found it.
  EXPECT_THAT(
      ParseSacctOutput(std::string("4||\xff\xff\xff\xff\xff\xff\xff\xff"
                                   "\xff\xff\xff\0\0JENING|Vsources|\n2|"
                                   "\xed\xedR\xed",
                                   39),
                       4),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("sacct printed no state for job 4")));
}

TEST(SlurmCliTest, BuildsSbatchArgvWithOptionsAndPathMapping) {
  SlurmOptions options;
  options.partition = "short";
  options.account = "lab";
  options.qos = "normal";
  options.cpus_per_task = 4;
  options.memory = "8G";
  options.time_limit = "01:00:00";
  options.extra_sbatch_args = {"--exclusive"};
  options.proc_path = "/opt/hdrstereo/bin/hdrstereo-proc";
  options.local_data_root = "/srv/hdrstereo";
  options.cluster_data_root = "/cluster/lab/hdrstereo";
  absl::StatusOr<std::vector<std::string>> argv =
      SbatchArgv(options, {.job_name = "hdrstereo-7",
                           .session_dir = "/srv/hdrstereo/sessions/it's",
                           .log_dir = "/srv/hdrstereo/sessions/it's/jobs/7",
                           .steps = {"stereo", "fusion"},
                           .force = true,
                           .job_dir = ""});
  ASSERT_TRUE(argv.ok()) << argv.status();
  EXPECT_THAT(
      *argv,
      ElementsAre(
          "sbatch", "--parsable", "--job-name=hdrstereo-7",
          "--output=/cluster/lab/hdrstereo/sessions/it's/jobs/7/slurm-%j.out",
          "--cpus-per-task=4", "--partition=short", "--account=lab",
          "--qos=normal", "--mem=8G", "--time=01:00:00", "--exclusive",
          "--wrap=exec '/opt/hdrstereo/bin/hdrstereo-proc' 'pipeline' "
          "'--session-dir' '/cluster/lab/hdrstereo/sessions/it'\\''s' "
          "'--threads' '4' '--steps' 'stereo,fusion' '--force'"));
  EXPECT_THAT(SbatchArgv(options, {.job_name = "hdrstereo-8",
                                   .session_dir = "/srv/hdrstereo-old/s",
                                   .log_dir = "/srv/hdrstereo-old/s/jobs/8",
                                   .steps = {},
                                   .force = false,
                                   .job_dir = ""}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("slurm.local_data_root")));
}

TEST(SlurmCliTest, AJobFolderCarriesTheRequestInsteadOfStepsAndForce) {
  SlurmOptions options;
  options.cpus_per_task = 2;
  options.local_data_root = "/srv/hdrstereo";
  options.cluster_data_root = "/cluster/hdrstereo";
  absl::StatusOr<std::vector<std::string>> argv =
      SbatchArgv(options, {.job_name = "hdrstereo-9",
                           .session_dir = "/srv/hdrstereo/sessions/s",
                           .log_dir = "/srv/hdrstereo/sessions/s/jobs/9",
                           .steps = {},
                           .force = false,
                           .job_dir = "/srv/hdrstereo/sessions/s/jobs/9"});
  ASSERT_TRUE(argv.ok()) << argv.status();
  EXPECT_EQ(argv->back(),
            "--wrap=exec 'hdrstereo-proc' 'pipeline' '--session-dir' "
            "'/cluster/hdrstereo/sessions/s' '--threads' '2' '--job-dir' "
            "'/cluster/hdrstereo/sessions/s/jobs/9'");
  EXPECT_THAT(
      SbatchArgv(options, {.job_name = "hdrstereo-9",
                           .session_dir = "/srv/hdrstereo/sessions/s",
                           .log_dir = "/srv/hdrstereo/sessions/s/jobs/9",
                           .steps = {"stereo"},
                           .force = false,
                           .job_dir = "/srv/hdrstereo/sessions/s/jobs/9"}),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("give neither")));
  EXPECT_THAT(
      SbatchArgv(options, {.job_name = "hdrstereo-9",
                           .session_dir = "/srv/hdrstereo/sessions/s",
                           .log_dir = "/srv/hdrstereo/sessions/s/jobs/9",
                           .steps = {},
                           .force = false,
                           .job_dir = "/elsewhere/jobs/9"}),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("slurm.local_data_root")));
}

// The node's log as the daemon reads its tail: other programs' lines, a
// line cut at the tail's start, a cluster log counting more steps done than
// planned ("[7/3]", which the CLI's progress bar once threw on).
TEST(SlurmCliTest, LastProgressIsTheLastWellFormedLine) {
  EXPECT_EQ(LastProgress("srun: job 4 queued\n"), std::nullopt);
  EXPECT_EQ(LastProgress("2/9] tonemap\n[3/9] stereo\n[x/9] bad\n[4/-1] no\n"
                         "slurmstepd: done\n"),
            (LogProgress{.done = 3, .total = 9, .what = "stereo"}));
  EXPECT_EQ(LastProgress("[7/3] fusion"),
            (LogProgress{.done = 7, .total = 3, .what = "fusion"}));
  const std::optional<LogProgress> long_step =
      LastProgress("[1/2] " + std::string(100000, 's'));
  ASSERT_TRUE(long_step.has_value());
  EXPECT_EQ(long_step->what.size(), kMaxFieldBytes);
}

}  // namespace
}  // namespace hdrstereo::slurm
