// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/slurm_processing.h"

#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "daemon/processing/command_runner.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::slurm {
namespace {

namespace fs = std::filesystem;

// Each client call's time limit: the controller answers in milliseconds
// when it is up.
constexpr absl::Duration kCommandTimeout = absl::Seconds(30);
// How long a scancelled job may take to leave the node.
constexpr absl::Duration kCancelWait = absl::Seconds(60);
constexpr size_t kLogTailBytes = 2000;
// The most bytes of each output stream a failed command's error quotes: its
// end, where a tool says what went wrong. RunCommand keeps one byte more
// than the parsers take, so that an oversized output is refused by them
// rather than parsed from a cut-off tail.
constexpr size_t kOutputTailBytes = 2000;

// What squeue and scontrol say of a job id the controller does not know.
bool Forgotten(const absl::Status& status) {
  return absl::StrContains(status.message(), "Invalid job id");
}

class Cluster {
 public:
  explicit Cluster(const SlurmOptions& options) : options_(options) {}

  // The command's output; UNAVAILABLE naming it for a non-zero exit.
  absl::StatusOr<process::CommandResult> Run(
      const std::vector<std::string>& argv) const {
    std::vector<std::string> env;
    if (!options_.conf.empty()) {
      env.push_back(absl::StrCat("SLURM_CONF=", options_.conf));
    }
    ASSIGN_OR_RETURN(
        process::CommandResult r,
        process::RunCommand(argv, env, kCommandTimeout, kMaxOutputBytes + 1));
    if (r.exit_code != 0) {
      std::string message =
          absl::StrCat(argv[0], " failed (exit ", r.exit_code, "): ",
                       QuoteInputTail(absl::StripTrailingAsciiWhitespace(r.err),
                                      kOutputTailBytes, r.err_dropped));
      if (!r.out.empty()) {
        absl::StrAppend(
            &message, "; stdout: ",
            QuoteInputTail(absl::StripTrailingAsciiWhitespace(r.out),
                           kOutputTailBytes, r.out_dropped));
      }
      return absl::UnavailableError(message);
    }
    return r;
  }

  // The job's state: squeue while it is queued or running; once it has
  // left the queue, accounting (sacct) where the cluster keeps it, else
  // scontrol; a job the controller has forgotten (MinJobAge after it ended)
  // and accounting does not know is state "GONE".
  absl::StatusOr<JobState> Query(int64_t id) const {
    absl::StatusOr<process::CommandResult> q = Run(SqueueArgv(id));
    if (q.ok()) {
      absl::StatusOr<JobState> queued = ParseSqueueOutput(q->out, id);
      if (queued.ok() && !IsFinal(queued->state)) return queued;
      if (!queued.ok() && !absl::IsNotFound(queued.status())) {
        return queued.status();
      }
    } else if (!Forgotten(q.status())) {
      return q.status();
    }
    if (absl::StatusOr<process::CommandResult> a = Run(SacctArgv(id)); a.ok()) {
      absl::StatusOr<JobState> recorded = ParseSacctOutput(a->out, id);
      if (recorded.ok() && IsFinal(recorded->state)) return recorded;
    }
    absl::StatusOr<process::CommandResult> c = Run(ScontrolArgv(id));
    if (c.ok()) return ParseScontrolOutput(c->out, id);
    if (!Forgotten(c.status())) return c.status();
    JobState gone;
    gone.state = "GONE";
    return gone;
  }

 private:
  const SlurmOptions& options_;
};

std::string ReadTail(const fs::path& path, size_t bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff start =
      size > static_cast<std::streamoff>(bytes) ? size - bytes : 0;
  in.seekg(start);
  std::string out(static_cast<size_t>(size - start), '\0');
  in.read(out.data(), static_cast<std::streamsize>(out.size()));
  return out;
}

absl::StatusOr<int64_t> Submit(const Cluster& cluster,
                               const SlurmOptions& options,
                               const pipeline::JobRequest& request,
                               const fs::path& job_dir,
                               jobs::JobContext& context) {
  std::error_code ec;
  fs::create_directories(job_dir, ec);
  if (ec) {
    return absl::InternalError(absl::StrCat(
        "cannot create the job folder ", job_dir.string(), ": ", ec.message()));
  }
  // A result left by an earlier submission of this job is not this one's.
  fs::remove(job_dir / pipeline::kJobResultFile, ec);
  RETURN_IF_ERROR(pipeline::WriteJobRequest(job_dir, request));
  const store::JobRecord& job = context.job();
  PipelineSubmission submission;
  submission.job_name = absl::StrCat("hdrstereo-", job.id);
  submission.session_dir =
      fs::absolute(request.input.session_dir).lexically_normal().string();
  submission.log_dir = job_dir.string();
  submission.job_dir = job_dir.string();
  ASSIGN_OR_RETURN(std::vector<std::string> argv,
                   SbatchArgv(options, submission));
  ASSIGN_OR_RETURN(process::CommandResult r, cluster.Run(argv));
  ASSIGN_OR_RETURN(int64_t id, ParseSbatchOutput(r.out));
  RETURN_IF_ERROR(
      store::JobRepository(context.store())
          .SetClusterJob(job.id, id,
                         absl::StrCat("submitted to Slurm as job ", id))
          .status());
  return id;
}

// scancel, then wait (bounded) until the batch job has left the node, so
// that nothing it writes afterwards is mistaken for a result.
void CancelOnCluster(const Cluster& cluster, int64_t id,
                     jobs::JobContext& context) {
  if (absl::Status s = cluster.Run(ScancelArgv(id)).status(); !s.ok()) {
    context.Warn(absl::StrCat("scancel ", id, ": ", s.message()));
    return;
  }
  const absl::Time deadline = absl::Now() + kCancelWait;
  while (absl::Now() < deadline) {
    absl::StatusOr<JobState> state = cluster.Query(id);
    if (state.ok() && (IsFinal(state->state) || state->state == "GONE")) {
      context.Info(absl::StrCat("Slurm job ", id, ": ", Describe(*state)));
      return;
    }
    absl::SleepFor(absl::Milliseconds(200));
  }
  context.Warn(absl::StrCat("Slurm job ", id, " had not ended ",
                            absl::FormatDuration(kCancelWait),
                            " after scancel"));
}

}  // namespace

absl::StatusOr<pipeline::JobResult> RunOnSlurm(
    const SlurmOptions& options, const pipeline::JobRequest& request,
    jobs::JobContext& context) {
  const store::JobRecord& job = context.job();
  // Absolute, so that the path mapping and the node's working folder do not
  // matter.
  const fs::path job_dir =
      fs::absolute(context.store().files().JobDir(job.session, job.id))
          .lexically_normal();
  const Cluster cluster(options);
  const absl::Duration poll = absl::Seconds(options.poll_s);

  int64_t id = 0;
  if (job.cluster_job_id.has_value()) {
    id = *job.cluster_job_id;
    context.Info(absl::StrCat("re-attached to Slurm job ", id));
  } else {
    ASSIGN_OR_RETURN(id, Submit(cluster, options, request, job_dir, context));
  }
  const fs::path log = job_dir / absl::StrCat("slurm-", id, ".out");

  std::string described;
  std::optional<LogProgress> progress;
  JobState state;
  for (;;) {
    if (absl::Status s = context.Checkpoint(); !s.ok()) {
      if (absl::IsCancelled(s)) CancelOnCluster(cluster, id, context);
      return s;  // ABORTED: the batch job runs on, to be re-attached
    }
    absl::StatusOr<JobState> queried = cluster.Query(id);
    if (!queried.ok()) {
      // The controller is down or unreachable: wait for it, suspended.
      RETURN_IF_ERROR(context.SuspendWhile(
          [&] {
            queried = cluster.Query(id);
            return queried.ok() ? std::string()
                                : absl::StrCat(
                                      "the Slurm controller does not "
                                      "answer: ",
                                      queried.status().message());
          },
          poll));
      if (!queried.ok()) continue;
    }
    state = *queried;
    if (const std::string now = Describe(state); now != described) {
      described = now;
      context.Info(absl::StrCat("Slurm job ", id, ": ", now));
    }
    if (std::optional<LogProgress> p = LastProgress(ReadTail(log, 4096));
        p && p != progress) {
      progress = p;
      // Progress is for people; a failure to record it must not fail the job.
      context.Progress(p->done, p->total, p->what).IgnoreError();
    }
    if (IsFinal(state.state) || state.state == "GONE") break;
    absl::SleepFor(poll);
  }

  absl::StatusOr<pipeline::JobResult> result = pipeline::ReadJobResult(job_dir);
  if (absl::IsDataLoss(result.status())) {
    // There is a result, and it is not one we accept (damaged, or naming a
    // file outside the session): nothing of it is recorded.
    return absl::DataLossError(
        absl::StrCat("Slurm job ", id, " ended ", Describe(state),
                     "; its result was refused: ", result.status().message()));
  }
  if (!result.ok()) {
    return absl::UnavailableError(
        absl::StrCat("Slurm job ", id, " ended ", Describe(state),
                     " without a result (", result.status().message(),
                     "); log tail:\n", ReadTail(log, kLogTailBytes)));
  }
  if (!result->status.ok()) {
    // The engine reads CANCELLED and ABORTED as its own; the run's are
    // failures.
    if (absl::IsCancelled(result->status) || absl::IsAborted(result->status)) {
      return absl::UnknownError(result->status.message());
    }
    return result->status;
  }
  for (const pipeline::StepRecord& step : result->steps) {
    RETURN_IF_ERROR(
        pipeline::VerifyArtifacts(request.input.session_dir, step.artifacts));
  }
  return result;
}

}  // namespace hdrstereo::slurm
