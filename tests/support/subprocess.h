// SPDX-License-Identifier: GPL-3.0-or-later
//
// Runs the project's real executables from tests: one-shot commands with
// captured output (daemon/processing/command_runner.h), and long-running
// processes (the daemon) that a test starts, signals and waits for.
#ifndef HDRSTEREO_TESTS_SUPPORT_SUBPROCESS_H_
#define HDRSTEREO_TESTS_SUPPORT_SUBPROCESS_H_

#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "daemon/processing/command_runner.h"

namespace hdrstereo::testing {

using process::CommandResult;

// process::RunCommand with the test's environment as it is.
inline absl::StatusOr<CommandResult> RunCommand(
    const std::vector<std::string>& argv,
    absl::Duration timeout = absl::Seconds(60)) {
  return process::RunCommand(argv, {}, timeout);
}

// A child process whose stdout and stderr go to a log file.
class Process {
 public:
  static absl::StatusOr<Process> Start(const std::vector<std::string>& argv,
                                       const std::filesystem::path& log_file);
  Process(Process&& other) noexcept;
  Process& operator=(Process&&) = delete;
  ~Process();  // SIGKILLs a child still running

  pid_t pid() const { return pid_; }
  void Signal(int signal_number);
  // The exit code (128 + signal when killed), or nullopt on timeout.
  std::optional<int> Wait(absl::Duration timeout);

 private:
  explicit Process(pid_t pid) : pid_(pid) {}
  pid_t pid_;
};

// Resident memory (VmRSS in /proc/<pid>/status) of process `pid`, in kB;
// -1 when it cannot be read.
int64_t ResidentKb(pid_t pid);

// Polls until `path` exists and is non-empty, or `timeout` passes.
bool WaitForFile(const std::filesystem::path& path, absl::Duration timeout);
// Polls until `path` exists (a socket, say), or `timeout` passes.
bool WaitForSocket(const std::filesystem::path& path, absl::Duration timeout);

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_SUBPROCESS_H_
