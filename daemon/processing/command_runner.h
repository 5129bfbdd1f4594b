// SPDX-License-Identifier: GPL-3.0-or-later
//
// Runs another program (a Slurm client tool) to its end within a time
// limit, with its output captured: the daemon's one way to call a command
// line, so that no call can hang a job.
#ifndef HDRSTEREO_DAEMON_PROCESSING_COMMAND_RUNNER_H_
#define HDRSTEREO_DAEMON_PROCESSING_COMMAND_RUNNER_H_

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace hdrstereo::process {

struct CommandResult {
  int exit_code = -1;  // 128 + signal number when killed by a signal
  std::string out;     // standard output
  std::string err;     // standard error
};

// Runs argv[0] (looked up in PATH unless it has a slash) with the daemon's
// environment plus `env` ("NAME=value", replacing a variable of that
// name), standard input /dev/null. After `timeout` the command is killed
// and DEADLINE_EXCEEDED carries its output so far; a command that cannot
// be started is the errno's status naming it. A non-zero exit is not an
// error here: the caller reads exit_code.
absl::StatusOr<CommandResult> RunCommand(const std::vector<std::string>& argv,
                                         const std::vector<std::string>& env,
                                         absl::Duration timeout);

// Waits for the child `pid` until `deadline`: its exit code (128 + signal
// number when killed, -1 when it cannot be waited for), or nullopt while it
// still runs.
std::optional<int> WaitForExit(pid_t pid, absl::Time deadline);

}  // namespace hdrstereo::process

#endif  // HDRSTEREO_DAEMON_PROCESSING_COMMAND_RUNNER_H_
