// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/processing/slurm_cli.h"

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::slurm {
namespace {

absl::Status CheckOutputSize(absl::string_view tool, absl::string_view out) {
  if (out.size() > kMaxOutputBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(tool, " printed ", out.size(), " bytes; the most is ",
                     kMaxOutputBytes));
  }
  return absl::OkStatus();
}

// The job's state from the fields a tool printed: a state, and each field
// within kMaxFieldBytes.
absl::StatusOr<JobState> MakeState(absl::string_view tool, int64_t job_id,
                                   absl::string_view state,
                                   absl::string_view reason,
                                   absl::string_view nodes,
                                   absl::string_view exit_code,
                                   absl::string_view std_out) {
  if (state.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(tool, " printed no state for job ", job_id));
  }
  for (const auto& [name, value] :
       {std::pair{"state", state}, std::pair{"reason", reason},
        std::pair{"node list", nodes}, std::pair{"exit code", exit_code},
        std::pair{"log path", std_out}}) {
    if (value.size() > kMaxFieldBytes) {
      return absl::InvalidArgumentError(absl::StrCat(
          tool, " printed a ", name, " of ", value.size(),
          " bytes: ", QuoteInput(value), "; the most is ", kMaxFieldBytes));
    }
  }
  return JobState{.state = std::string(state),
                  .reason = std::string(reason),
                  .nodes = std::string(nodes),
                  .exit_code = std::string(exit_code),
                  .std_out = std::string(std_out)};
}

}  // namespace

absl::StatusOr<std::string> ToClusterPath(const SlurmOptions& options,
                                          absl::string_view path) {
  if (options.local_data_root.empty() && options.cluster_data_root.empty()) {
    return std::string(path);
  }
  absl::string_view rest = path;
  if (!absl::ConsumePrefix(&rest, options.local_data_root) ||
      !(rest.empty() || rest.front() == '/')) {
    return absl::InvalidArgumentError(
        absl::StrCat("slurm.local_data_root: \"", path, "\" is not below \"",
                     options.local_data_root, "\""));
  }
  return absl::StrCat(options.cluster_data_root, rest);
}

absl::StatusOr<std::vector<std::string>> SbatchArgv(
    const SlurmOptions& options, const PipelineSubmission& submission) {
  ASSIGN_OR_RETURN(std::string session,
                   ToClusterPath(options, submission.session_dir));
  ASSIGN_OR_RETURN(std::string log_dir,
                   ToClusterPath(options, submission.log_dir));
  std::vector<std::string> argv = {
      "sbatch", "--parsable", absl::StrCat("--job-name=", submission.job_name),
      absl::StrCat("--output=", log_dir, "/slurm-%j.out"),
      absl::StrCat("--cpus-per-task=", options.cpus_per_task)};
  if (!options.partition.empty()) {
    argv.push_back(absl::StrCat("--partition=", options.partition));
  }
  if (!options.account.empty()) {
    argv.push_back(absl::StrCat("--account=", options.account));
  }
  if (!options.qos.empty()) argv.push_back(absl::StrCat("--qos=", options.qos));
  if (!options.memory.empty()) {
    argv.push_back(absl::StrCat("--mem=", options.memory));
  }
  if (!options.time_limit.empty()) {
    argv.push_back(absl::StrCat("--time=", options.time_limit));
  }
  argv.insert(argv.end(), options.extra_sbatch_args.begin(),
              options.extra_sbatch_args.end());
  // --wrap takes one shell line: quote every word.
  std::vector<std::string> words = {
      options.proc_path, "pipeline",  "--session-dir",
      session,           "--threads", absl::StrCat(options.cpus_per_task)};
  if (!submission.job_dir.empty()) {
    if (!submission.steps.empty() || submission.force) {
      return absl::InvalidArgumentError(
          "a job folder's request names the steps and force; give neither");
    }
    ASSIGN_OR_RETURN(std::string job_dir,
                     ToClusterPath(options, submission.job_dir));
    words.push_back("--job-dir");
    words.push_back(job_dir);
  }
  if (!submission.steps.empty()) {
    words.push_back("--steps");
    words.push_back(absl::StrJoin(submission.steps, ","));
  }
  if (submission.force) words.push_back("--force");
  std::vector<std::string> quoted;
  for (const std::string& w : words) {
    quoted.push_back(
        absl::StrCat("'", absl::StrReplaceAll(w, {{"'", "'\\''"}}), "'"));
  }
  argv.push_back(absl::StrCat("--wrap=exec ", absl::StrJoin(quoted, " ")));
  return argv;
}

absl::StatusOr<int64_t> ParseSbatchOutput(absl::string_view out) {
  RETURN_IF_ERROR(CheckOutputSize("sbatch", out));
  absl::string_view line = absl::StripAsciiWhitespace(out);
  absl::string_view id = line.substr(0, line.find(';'));
  int64_t job_id = 0;
  if (!absl::SimpleAtoi(id, &job_id)) {
    return absl::InvalidArgumentError(
        absl::StrCat("sbatch printed no job id: ", QuoteInput(line)));
  }
  RETURN_IF_ERROR(CheckRange("sbatch job id", job_id, 1, kMaxJobId));
  return job_id;
}

std::vector<std::string> SqueueArgv(int64_t job_id) {
  return {"squeue", "-h",
          "-j",     absl::StrCat(job_id),
          "-o",     std::string(kSqueueFormat)};
}

absl::StatusOr<JobState> ParseSqueueOutput(absl::string_view out,
                                           int64_t job_id) {
  RETURN_IF_ERROR(CheckOutputSize("squeue", out));
  for (absl::string_view line : absl::StrSplit(out, '\n', absl::SkipEmpty())) {
    if (std::count(line.begin(), line.end(), '|') != 3) {
      return absl::InvalidArgumentError(
          absl::StrCat("squeue line ", QuoteInput(line),
                       " does not have 4 fields (", kSqueueFormat, ")"));
    }
    std::vector<absl::string_view> fields = absl::StrSplit(line, '|');
    if (fields[0] != absl::StrCat(job_id)) continue;
    return MakeState("squeue", job_id, fields[1], fields[2],
                     absl::StripAsciiWhitespace(fields[3]), "", "");
  }
  return absl::NotFoundError(
      absl::StrCat("Slurm job ", job_id, " is not in the queue"));
}

std::vector<std::string> ScontrolArgv(int64_t job_id) {
  return {"scontrol", "show", "job", "-o", absl::StrCat(job_id)};
}

absl::StatusOr<JobState> ParseScontrolOutput(absl::string_view out,
                                             int64_t job_id) {
  RETURN_IF_ERROR(CheckOutputSize("scontrol", out));
  // Values hold no spaces in -o output except Command= and similar paths,
  // which this parser does not read.
  std::map<std::string, std::string, std::less<>> fields;
  for (absl::string_view word : absl::StrSplit(absl::StripAsciiWhitespace(out),
                                               ' ', absl::SkipEmpty())) {
    std::pair<std::string, std::string> kv =
        absl::StrSplit(word, absl::MaxSplits('=', 1));
    fields.emplace(std::move(kv.first), std::move(kv.second));
  }
  auto get = [&](absl::string_view key) {
    auto it = fields.find(key);
    return it == fields.end() ? std::string() : it->second;
  };
  if (get("JobId") != absl::StrCat(job_id) || get("JobState").empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "scontrol show job ", job_id, " printed no JobId/JobState: ",
        QuoteInput(absl::StripAsciiWhitespace(out))));
  }
  return MakeState("scontrol", job_id, get("JobState"), get("Reason"),
                   get("NodeList"), get("ExitCode"), get("StdOut"));
}

std::vector<std::string> SacctArgv(int64_t job_id) {
  return {"sacct", "-n",
          "-P",    "-X",
          "-j",    absl::StrCat(job_id),
          "-o",    std::string(kSacctFormat)};
}

absl::StatusOr<JobState> ParseSacctOutput(absl::string_view out,
                                          int64_t job_id) {
  RETURN_IF_ERROR(CheckOutputSize("sacct", out));
  for (absl::string_view line : absl::StrSplit(out, '\n', absl::SkipEmpty())) {
    if (std::count(line.begin(), line.end(), '|') != 4) {
      return absl::InvalidArgumentError(
          absl::StrCat("sacct line ", QuoteInput(line),
                       " does not have 5 fields (", kSacctFormat, ")"));
    }
    std::vector<absl::string_view> fields = absl::StrSplit(line, '|');
    if (fields[0] != absl::StrCat(job_id)) continue;
    return MakeState("sacct", job_id, fields[1], fields[4], fields[3],
                     fields[2], "");
  }
  return absl::NotFoundError(
      absl::StrCat("Slurm's accounting has no record of job ", job_id));
}

std::vector<std::string> ScancelArgv(int64_t job_id) {
  return {"scancel", absl::StrCat(job_id)};
}

bool IsFinal(absl::string_view state) {
  static constexpr absl::string_view kFinal[] = {
      "BOOT_FAIL", "CANCELLED",     "COMPLETED", "DEADLINE", "FAILED",
      "NODE_FAIL", "OUT_OF_MEMORY", "PREEMPTED", "TIMEOUT"};
  // scontrol may append a qualifier ("CANCELLED by 0" in sacct).
  absl::string_view word = state.substr(0, state.find(' '));
  for (absl::string_view f : kFinal) {
    if (word == f) return true;
  }
  return false;
}

std::string Describe(const JobState& s) {
  if (s.state == "RUNNING" || s.state == "COMPLETING") {
    return absl::StrCat(s.state, " on node ", s.nodes);
  }
  std::vector<std::string> details;
  if (!s.reason.empty() && s.reason != "None") details.push_back(s.reason);
  if (IsFinal(s.state) && !s.exit_code.empty() && s.exit_code != "0:0") {
    details.push_back(absl::StrCat("exit ", s.exit_code));
  }
  if (details.empty()) return s.state;
  return absl::StrCat(s.state, " (", absl::StrJoin(details, ", "), ")");
}

std::optional<LogProgress> LastProgress(absl::string_view log) {
  std::optional<LogProgress> last;
  for (absl::string_view line : absl::StrSplit(log, '\n')) {
    if (!absl::ConsumePrefix(&line, "[")) continue;
    const size_t close = line.find("] ");
    if (close == absl::string_view::npos) continue;
    std::pair<absl::string_view, absl::string_view> counts =
        absl::StrSplit(line.substr(0, close), absl::MaxSplits('/', 1));
    LogProgress p;
    if (!absl::SimpleAtoi(counts.first, &p.done) ||
        !absl::SimpleAtoi(counts.second, &p.total) || p.done < 0 ||
        p.total < 0) {
      continue;
    }
    p.what = std::string(line.substr(close + 2, kMaxFieldBytes));
    last = std::move(p);
  }
  return last;
}

}  // namespace hdrstereo::slurm
