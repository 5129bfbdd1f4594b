// SPDX-License-Identifier: GPL-3.0-or-later
//
// Slurm through its own command-line tools (sbatch, squeue, scontrol,
// scancel), never REST or libslurm: the argument lists this module builds
// and the parsers of their plain output (`--parsable`, `-o` formats and
// `scontrol show job -o`), not `--json`, whose schema changes between Slurm
// versions. Running the commands is the caller's (each call bounded in
// time); this module holds no state.
#ifndef HDRSTEREO_DAEMON_PROCESSING_SLURM_CLI_H_
#define HDRSTEREO_DAEMON_PROCESSING_SLURM_CLI_H_

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::slurm {

// Limits on what the tools print (their output is outside input: a
// cluster's tools, or whatever stands in their place on the PATH). One job's
// squeue, sacct or scontrol output is a line of at most a few KB.
inline constexpr size_t kMaxOutputBytes = size_t{1} << 20;
// A job id is a 32-bit unsigned number in Slurm.
inline constexpr int64_t kMaxJobId = 4294967295;
// A state, reason, node list, exit code or log path (PATH_MAX).
inline constexpr size_t kMaxFieldBytes = 4096;

// The [slurm] options of the daemon's config.
struct SlurmOptions {
  std::string partition;  // empty = the cluster's default
  std::string account;
  std::string qos;
  int cpus_per_task = 2;
  std::string memory;      // sbatch --mem, e.g. "4G"; empty = default
  std::string time_limit;  // sbatch --time, e.g. "01:00:00"; empty = default
  std::vector<std::string> extra_sbatch_args;
  // hdrstereo-proc as the compute nodes see it.
  std::string proc_path = "hdrstereo-proc";
  // The data root as the daemon sees it and as the nodes mount it (both
  // empty = the same path everywhere).
  std::string local_data_root;
  std::string cluster_data_root;
  // SLURM_CONF for the client tools the daemon runs; empty = their default
  // (/etc/slurm/slurm.conf or the daemon's own SLURM_CONF).
  std::string conf;
  // How often a running job's state is asked for.
  double poll_s = 5;
};

// One job to submit: the pipeline on one session folder.
struct PipelineSubmission {
  std::string job_name;     // hdrstereo-<job id>
  std::string session_dir;  // as the daemon sees it
  std::string log_dir;      // as the daemon sees it; slurm-%j.out goes here
  std::vector<std::string> steps;  // empty = all
  bool force = false;
  // The daemon's job folder (as the daemon sees it): when set, the run reads
  // its request there and writes its result there (hdrstereo-proc pipeline
  // --job-dir), and `steps` and `force` must be left empty.
  std::string job_dir;
};

// `path` with the local data root replaced by the cluster's. INVALID_ARGUMENT
// when a mapping is configured and `path` is not below the local root.
absl::StatusOr<std::string> ToClusterPath(const SlurmOptions& options,
                                          absl::string_view path);

// sbatch --parsable --job-name=... --output=<log_dir>/slurm-%j.out ...
// wrapping `hdrstereo-proc pipeline --session-dir ...` (argv, sbatch first).
// INVALID_ARGUMENT for a path outside the mapping, or steps or force given
// with a job folder.
absl::StatusOr<std::vector<std::string>> SbatchArgv(
    const SlurmOptions& options, const PipelineSubmission& submission);

// The job id from `sbatch --parsable` ("123" or "123;cluster").
// INVALID_ARGUMENT quoting the output otherwise, or naming an id outside
// [1, kMaxJobId].
//
// Every parser here answers INVALID_ARGUMENT for output longer than
// kMaxOutputBytes, for a field longer than kMaxFieldBytes (naming the
// tool, the field and the limit) and for a job's line without a state, and
// quotes what it received bounded (QuoteInput).
absl::StatusOr<int64_t> ParseSbatchOutput(absl::string_view out);

struct JobState {
  std::string state;      // PENDING, RUNNING, COMPLETED, FAILED, CANCELLED, ...
  std::string reason;     // Priority, Resources, NonZeroExitCode, None, ...
  std::string nodes;      // empty while pending
  std::string exit_code;  // scontrol's "code:signal"; empty from squeue
  std::string std_out;    // the job's log (scontrol only)
};

// squeue -h -j <id> -o "%i|%T|%r|%N" (the format kSqueueFormat).
inline constexpr absl::string_view kSqueueFormat = "%i|%T|%r|%N";
std::vector<std::string> SqueueArgv(int64_t job_id);
// NOT_FOUND for empty output (the job has left the queue), INVALID_ARGUMENT
// quoting a line that does not have the format's four fields.
absl::StatusOr<JobState> ParseSqueueOutput(absl::string_view out,
                                           int64_t job_id);

// scontrol show job -o <id>: one line of Key=Value pairs.
std::vector<std::string> ScontrolArgv(int64_t job_id);
// INVALID_ARGUMENT when the line lacks JobId=<job_id> or JobState.
absl::StatusOr<JobState> ParseScontrolOutput(absl::string_view out,
                                             int64_t job_id);

// sacct -n -P -X -j <id> -o JobID,State,ExitCode,NodeList,Reason: the
// accounting record, the only source once the controller has forgotten an
// ended job (MinJobAge) and when accounting is configured.
inline constexpr absl::string_view kSacctFormat =
    "JobID,State,ExitCode,NodeList,Reason";
std::vector<std::string> SacctArgv(int64_t job_id);
// NOT_FOUND for no record of the job, INVALID_ARGUMENT quoting a line that
// does not have the format's five fields.
absl::StatusOr<JobState> ParseSacctOutput(absl::string_view out,
                                          int64_t job_id);

std::vector<std::string> ScancelArgv(int64_t job_id);

// Progress that `hdrstereo-proc pipeline` prints to the job's log, one
// "[done/total] what" line per step.
struct LogProgress {
  int64_t done = 0;
  int64_t total = 0;
  std::string what;  // at most kMaxFieldBytes
  bool operator==(const LogProgress&) const = default;
};
// The last well-formed progress line of `log` (a tail of the log: lines
// of other programs and a cut first line are skipped); nullopt when none.
std::optional<LogProgress> LastProgress(absl::string_view log);

// Whether Slurm will not change `state` any more.
bool IsFinal(absl::string_view state);

// For the job's events: "PENDING (Priority)", "RUNNING on node c12",
// "FAILED (NonZeroExitCode, exit 1:0)".
std::string Describe(const JobState& state);

}  // namespace hdrstereo::slurm

#endif  // HDRSTEREO_DAEMON_PROCESSING_SLURM_CLI_H_
