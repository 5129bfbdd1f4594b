// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/subprocess.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <thread>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"

extern char** environ;

namespace hdrstereo::testing {
namespace {

std::vector<char*> ArgvPointers(const std::vector<std::string>& argv) {
  std::vector<char*> pointers;
  for (const std::string& arg : argv) {
    pointers.push_back(const_cast<char*>(arg.c_str()));
  }
  pointers.push_back(nullptr);
  return pointers;
}

}  // namespace

absl::StatusOr<Process> Process::Start(const std::vector<std::string>& argv,
                                       const std::filesystem::path& log_file) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_file.c_str(),
                                   O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null",
                                   O_RDONLY, 0);
  pid_t pid = 0;
  std::vector<char*> args = ArgvPointers(argv);
  int rc =
      ::posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0)
    return absl::ErrnoToStatus(rc, absl::StrCat("cannot run ", argv[0]));
  return Process(pid);
}

Process::Process(Process&& other) noexcept
    : pid_(std::exchange(other.pid_, -1)) {}

Process::~Process() {
  if (pid_ > 0) {
    ::kill(pid_, SIGKILL);
    process::WaitForExit(pid_, absl::Now() + absl::Seconds(10));
  }
}

void Process::Signal(int signal_number) {
  if (pid_ > 0) ::kill(pid_, signal_number);
}

std::optional<int> Process::Wait(absl::Duration timeout) {
  if (pid_ <= 0) return std::nullopt;
  std::optional<int> code = process::WaitForExit(pid_, absl::Now() + timeout);
  if (code.has_value()) pid_ = -1;
  return code;
}

int64_t ResidentKb(pid_t pid) {
  std::ifstream in(absl::StrCat("/proc/", pid, "/status"));
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) {
      int64_t kb = 0;
      std::vector<std::string> parts =
          absl::StrSplit(line, ' ', absl::SkipEmpty());
      if (parts.size() >= 2 && absl::SimpleAtoi(parts[1], &kb)) return kb;
    }
  }
  return -1;
}

bool WaitForFile(const std::filesystem::path& path, absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  std::error_code ec;
  while (absl::Now() < deadline) {
    if (std::filesystem::file_size(path, ec) > 0 && !ec) return true;
    absl::SleepFor(absl::Milliseconds(20));
  }
  return false;
}

bool WaitForSocket(const std::filesystem::path& path, absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  std::error_code ec;
  while (absl::Now() < deadline) {
    if (std::filesystem::exists(path, ec)) return true;
    absl::SleepFor(absl::Milliseconds(20));
  }
  return false;
}

}  // namespace hdrstereo::testing
