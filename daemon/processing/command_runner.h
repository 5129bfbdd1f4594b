// SPDX-License-Identifier: GPL-3.0-or-later
//
// Runs another program (a Slurm client tool) to its end within a time
// limit, with its output captured: the daemon's one way to call a command
// line, so that no call can hang a job.
#ifndef HDRSTEREO_DAEMON_PROCESSING_COMMAND_RUNNER_H_
#define HDRSTEREO_DAEMON_PROCESSING_COMMAND_RUNNER_H_

#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace hdrstereo::process {

// The most bytes RunCommand keeps of each of a command's standard output
// and standard error: the last ones (a tool's summary or error comes last);
// what came before is dropped and counted, so that a runaway command cannot
// fill the daemon's memory. Slurm's tools print kilobytes.
inline constexpr size_t kMaxCommandOutputBytes = size_t{16} << 20;

struct CommandResult {
  int exit_code = -1;  // 128 + signal number when killed by a signal
  std::string out;     // standard output (its last bytes, see below)
  std::string err;     // standard error (its last bytes, see below)
  // Bytes dropped from the front of `out` and `err` to keep each within the
  // limit; 0 when the stream is complete.
  int64_t out_dropped = 0;
  int64_t err_dropped = 0;
};

// Runs argv[0] (looked up in PATH unless it has a slash) with the daemon's
// environment plus `env` ("NAME=value", replacing a variable of that
// name), standard input /dev/null. Of each output stream the last
// `max_output_bytes` are kept: a stream's text grows to at most 1.5 times
// that plus one 4 KiB read before its front is dropped, so its buffer
// (grown by doubling) stays under 3 times that plus 8 KiB. After `timeout`
// the command is killed and DEADLINE_EXCEEDED quotes the end of what it had
// printed on each stream (QuoteInputTail: the last kMaxQuotedBytes, and how
// many bytes came before); a command that cannot be started is the errno's
// status naming it; a pipe that cannot be made is the errno's status of
// "pipe" (EMFILE: RESOURCE_EXHAUSTED). Every descriptor opened here is
// closed on every path. A non-zero exit is not an error here: the caller
// reads exit_code.
absl::StatusOr<CommandResult> RunCommand(
    const std::vector<std::string>& argv, const std::vector<std::string>& env,
    absl::Duration timeout, size_t max_output_bytes = kMaxCommandOutputBytes);

// Waits for the child `pid` until `deadline`: its exit code (128 + signal
// number when killed, -1 when it cannot be waited for), or nullopt while it
// still runs.
std::optional<int> WaitForExit(pid_t pid, absl::Time deadline);

}  // namespace hdrstereo::process

#endif  // HDRSTEREO_DAEMON_PROCESSING_COMMAND_RUNNER_H_
