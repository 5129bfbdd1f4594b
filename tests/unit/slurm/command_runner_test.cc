// SPDX-License-Identifier: GPL-3.0-or-later
//
// The daemon's way to run a command line: output captured, PATH searched,
// environment entries added or replaced, a time limit that kills, and a
// program that is not there named in the error.
#include "daemon/processing/command_runner.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>

#include "tests/support/status_matchers.h"

namespace hdrstereo::process {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

TEST(CommandRunnerTest, CapturesOutputAndExitCodeFromAProgramInPath) {
  ASSERT_OK_AND_ASSIGN(
      CommandResult r,
      RunCommand({"sh", "-c", "echo out; echo err >&2; exit 3"}, {},
                 absl::Seconds(10)));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.out, "out\n");
  EXPECT_EQ(r.err, "err\n");
}

TEST(CommandRunnerTest, EnvironmentEntriesAreAddedOrReplaced) {
  ::setenv("HDRSTEREO_RUNNER_TEST", "from the daemon", 1);
  ASSERT_OK_AND_ASSIGN(
      CommandResult r,
      RunCommand({"sh", "-c", "echo \"$HDRSTEREO_RUNNER_TEST|$SLURM_CONF\""},
                 {"SLURM_CONF=/etc/lab/slurm.conf"}, absl::Seconds(10)));
  EXPECT_EQ(r.out, "from the daemon|/etc/lab/slurm.conf\n");
  ASSERT_OK_AND_ASSIGN(
      r, RunCommand({"sh", "-c", "echo \"$HDRSTEREO_RUNNER_TEST\""},
                    {"HDRSTEREO_RUNNER_TEST=replaced"}, absl::Seconds(10)));
  EXPECT_EQ(r.out, "replaced\n");
  ::unsetenv("HDRSTEREO_RUNNER_TEST");
}

TEST(CommandRunnerTest, ACommandPastItsLimitIsKilledWithItsOutputSoFar) {
  EXPECT_THAT(
      RunCommand({"sh", "-c", "echo started; exec sleep 30"}, {},
                 absl::Milliseconds(300)),
      StatusIs(absl::StatusCode::kDeadlineExceeded,
               HasSubstr("did not finish within 300ms; output so far: "
                         "started")));
}

TEST(CommandRunnerTest, AMissingProgramIsNamed) {
  EXPECT_THAT(RunCommand({"hdrstereo-no-such-tool"}, {}, absl::Seconds(5)),
              StatusIs(absl::StatusCode::kNotFound,
                       HasSubstr("cannot run hdrstereo-no-such-tool")));
  EXPECT_THAT(RunCommand({}, {}, absl::Seconds(5)),
              StatusIs(absl::StatusCode::kInvalidArgument));
}

}  // namespace
}  // namespace hdrstereo::process
