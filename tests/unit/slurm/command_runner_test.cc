// SPDX-License-Identifier: GPL-3.0-or-later
//
// The daemon's way to run a command line: output captured (its tail, within
// a limit), PATH searched, environment entries added or replaced, a time
// limit that kills, a program that is not there named in the error, and no
// descriptor left open on any path.
#include "daemon/processing/command_runner.h"

#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
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
  EXPECT_THAT(RunCommand({"sh", "-c", "echo started; exec sleep 30"}, {},
                         absl::Milliseconds(300)),
              StatusIs(absl::StatusCode::kDeadlineExceeded,
                       HasSubstr("did not finish within 300ms; the end of its "
                                 "output: \"started\\n\", of its standard "
                                 "error: \"\"")));
}

// What a runaway command printed is quoted in the error by its last
// kMaxQuotedBytes (64), with the count of the bytes before them: those the
// quote leaves out plus those the runner dropped to keep its limit.
TEST(CommandRunnerTest, TheTimeoutMessageQuotesTheEndOfTheOutput) {
  // 100000 x, then 4 more bytes: 99940 before the last 64.
  const std::string expected =
      absl::StrCat("the end of its output: (99940 bytes left out) ...\"",
                   std::string(60, 'x'), "LAST\", of its standard error: \"\"");
  for (size_t max_output_bytes : {kMaxCommandOutputBytes, size_t{1000}}) {
    SCOPED_TRACE(max_output_bytes);
    absl::StatusOr<CommandResult> r = RunCommand(
        {"sh", "-c",
         "head -c 100000 /dev/zero | tr '\\0' x; printf LAST; exec sleep 30"},
        {}, absl::Seconds(2), max_output_bytes);
    EXPECT_THAT(
        r, StatusIs(absl::StatusCode::kDeadlineExceeded, HasSubstr(expected)));
    EXPECT_LT(r.status().message().size(), 200u) << r.status().message();
  }
}

// A command printing far more than the limit: the runner keeps the last
// `max_output_bytes` of it (consecutive numbers up to the last one) and
// counts what it dropped.
TEST(CommandRunnerTest, KeepsOnlyTheTailOfALargeOutput) {
  constexpr size_t kLimit = 64 << 10;
  // seq 1 1000000 prints 6888896 bytes.
  constexpr int64_t kTotal = 6888896;
  ASSERT_OK_AND_ASSIGN(CommandResult r,
                       RunCommand({"sh", "-c", "seq 1 1000000; echo done >&2"},
                                  {}, absl::Seconds(60), kLimit));
  EXPECT_EQ(r.exit_code, 0);
  ASSERT_EQ(r.out.size(), kLimit);
  EXPECT_EQ(r.out_dropped, kTotal - static_cast<int64_t>(kLimit));
  EXPECT_EQ(r.err, "done\n");
  EXPECT_EQ(r.err_dropped, 0);
  // After the first (cut) line: every number follows the one before, up to
  // 1000000.
  std::vector<std::string> lines =
      absl::StrSplit(r.out.substr(r.out.find('\n') + 1), '\n');
  ASSERT_EQ(lines.back(), "");
  lines.pop_back();
  ASSERT_GT(lines.size(), 1000u);
  EXPECT_EQ(lines.back(), "1000000");
  int64_t expected = 1000000 - static_cast<int64_t>(lines.size()) + 1;
  for (const std::string& line : lines) {
    ASSERT_EQ(line, std::to_string(expected)) << "out of sequence";
    ++expected;
  }
}

// The runner's memory does not grow with a command's output: 79 MB through
// a 64 KiB limit raise the peak resident set (ru_maxrss, KiB) by less than
// 8 MiB. Measured in a forked child (EXPECT_EXIT), whose peak starts from
// its own pages, so that an earlier peak of this process cannot hide the
// growth; the child exits 1 when the peak grew too much and says what it
// kept.
TEST(CommandRunnerTest, MemoryDoesNotGrowWithTheOutput) {
  constexpr size_t kLimit = 64 << 10;
  EXPECT_EXIT(
      {
        rusage before{};
        ::getrusage(RUSAGE_SELF, &before);
        // seq 1 10000000 prints 78888897 bytes.
        const absl::StatusOr<CommandResult> r =
            RunCommand({"seq", "1", "10000000"}, {}, absl::Seconds(60), kLimit);
        rusage after{};
        ::getrusage(RUSAGE_SELF, &after);
        const int64_t grown_kib = after.ru_maxrss - before.ru_maxrss;
        std::fputs(absl::StrCat(r.status().ToString(), "; kept ",
                                r.ok() ? r->out.size() : 0, " bytes, dropped ",
                                r.ok() ? r->out_dropped : 0,
                                "; the peak grew by ", grown_kib, " KiB\n")
                       .c_str(),
                   stderr);
        std::exit(grown_kib < 8 * 1024 ? 0 : 1);
      },
      ::testing::ExitedWithCode(0),
      "OK; kept 65536 bytes, dropped 78823361; the peak grew by");
}

// Counts this process's open descriptors.
int OpenFds() {
  int n = 0;
  for ([[maybe_unused]] const auto& e :
       std::filesystem::directory_iterator("/proc/self/fd")) {
    ++n;
  }
  return n;
}

// The first pipe is made and the second fails (the descriptor limit lowered
// to leave room for exactly two more): RunCommand fails naming the pipe and
// closes the first.
TEST(CommandRunnerTest, ASecondPipeThatFailsLeaksNoDescriptor) {
  // The three lowest free descriptors: pipe2 takes the lowest free ones.
  std::vector<int> free_fds;
  for (int fd = 0; free_fds.size() < 3; ++fd) {
    if (::fcntl(fd, F_GETFD) < 0) free_fds.push_back(fd);
  }
  const int fds_before = OpenFds();
  rlimit saved{};
  ASSERT_EQ(::getrlimit(RLIMIT_NOFILE, &saved), 0);
  rlimit lowered = saved;
  lowered.rlim_cur = static_cast<rlim_t>(free_fds[2]);
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &lowered), 0);
  const absl::StatusOr<CommandResult> r =
      RunCommand({"true"}, {}, absl::Seconds(10));
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &saved), 0);
  EXPECT_THAT(r, StatusIs(absl::StatusCode::kResourceExhausted,
                          HasSubstr("pipe: Too many open files")));
  EXPECT_LT(::fcntl(free_fds[0], F_GETFD), 0) << "first pipe left open";
  EXPECT_LT(::fcntl(free_fds[1], F_GETFD), 0) << "first pipe left open";
  EXPECT_EQ(OpenFds(), fds_before);
}

// Every descriptor is closed after a normal run and after a timeout.
TEST(CommandRunnerTest, ClosesEveryDescriptor) {
  const int fds_before = OpenFds();
  ASSERT_OK_AND_ASSIGN(CommandResult r,
                       RunCommand({"sh", "-c", "echo out; echo err >&2"}, {},
                                  absl::Seconds(10)));
  EXPECT_EQ(r.out, "out\n");
  EXPECT_THAT(RunCommand({"sleep", "30"}, {}, absl::Milliseconds(100)),
              StatusIs(absl::StatusCode::kDeadlineExceeded,
                       HasSubstr("sleep did not finish within 100ms")));
  EXPECT_EQ(OpenFds(), fds_before);
}

// What this process ignores or blocks (the daemon: SIGPIPE once a PTP/IP
// camera is open, the signals it takes with sigwait) is not the child's:
// it starts with SIGPIPE at its default and nothing blocked.
TEST(CommandRunnerTest, TheChildStartsWithDefaultSignals) {
  struct sigaction ignore = {}, before = {};
  ignore.sa_handler = SIG_IGN;
  ASSERT_EQ(sigaction(SIGPIPE, &ignore, &before), 0);
  sigset_t block, mask_before;
  sigemptyset(&block);
  sigaddset(&block, SIGTERM);
  ASSERT_EQ(pthread_sigmask(SIG_BLOCK, &block, &mask_before), 0);
  absl::StatusOr<CommandResult> r =
      RunCommand({"sh", "-c", "grep -E '^Sig(Ign|Blk)' /proc/self/status"}, {},
                 absl::Seconds(10));
  pthread_sigmask(SIG_SETMASK, &mask_before, nullptr);
  sigaction(SIGPIPE, &before, nullptr);
  ASSERT_TRUE(r.ok()) << r.status();
  // Bit 13 (SIGPIPE, signal 13) of SigIgn, bit 15 (SIGTERM) of SigBlk, in
  // hexadecimal masks: the shell's own settings leave both clear.
  uint64_t ignored = ~0ull, blocked = ~0ull;
  for (absl::string_view line : absl::StrSplit(r->out, '\n')) {
    const std::vector<std::string> field = absl::StrSplit(line, '\t');
    if (field.size() != 2) continue;
    const uint64_t mask = std::stoull(field[1], nullptr, 16);
    if (field[0] == "SigIgn:") ignored = mask;
    if (field[0] == "SigBlk:") blocked = mask;
  }
  EXPECT_EQ(ignored & (1ull << (SIGPIPE - 1)), 0u) << r->out;
  EXPECT_EQ(blocked & (1ull << (SIGTERM - 1)), 0u) << r->out;
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
