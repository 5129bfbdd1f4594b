// SPDX-License-Identifier: GPL-3.0-or-later
//
// Processing jobs: run the session pipeline (processing/pipeline) on what a
// session's captures recorded, record every output file as an artifact and
// the evaluation as metrics rows. The job's request is a serialized
// v1::SubmitProcessingRequest.
#ifndef HDRSTEREO_DAEMON_JOBS_PROCESSING_JOB_H_
#define HDRSTEREO_DAEMON_JOBS_PROCESSING_JOB_H_

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/processing/slurm_cli.h"
#include "hardware/rig.h"
#include "hdrstereo/v1/jobs.pb.h"

namespace hdrstereo::jobs {

// What a processing job may take of memory: checked against the
// pipeline's estimate (processing/pipeline/memory_estimate.h) when the job
// is submitted and again before it starts.
struct MemoryBudget {
  int64_t bytes = 0;   // 0 = not checked
  std::string source;  // where it comes from, for the refusal
};

struct ProcessingEnvironment {
  int threads = 2;  // for the pipeline's independent steps
  MemoryBudget memory;
  // Set: every job runs as a Slurm batch job (--processing-backend slurm,
  // daemon/jobs/slurm_processing.h); unset: in this process.
  std::optional<slurm::SlurmOptions> slurm;
  // Shown in the report's capture summary ("hardware", "simulated: ...").
  std::vector<std::pair<std::string, std::string>> summary;
};

// Validates `request` (session name, step names) and queues a processing
// job. INVALID_ARGUMENT for an unknown step (listing the known ones),
// NOT_FOUND for an unknown session, FAILED_PRECONDITION when the session
// has nothing to process: no stereo capture, or only incomplete ones (the
// error names the capture and its first missing frame), RESOURCE_EXHAUSTED
// when the run would need more memory than `environment.memory` (naming
// how much, for which steps and frames; frames of unknown size, RAW, are
// not checked). Captures of the session still queued or running count as
// future input: the job waits for them, and checks them and its memory,
// when it starts (a job already on Slurm is followed unchecked). The job
// records `submitted_by` as its principal.
absl::StatusOr<store::JobRecord> SubmitProcessing(
    JobEngine& engine, const hardware::Rig& rig,
    const ProcessingEnvironment& environment,
    const v1::SubmitProcessingRequest& request, absl::string_view submitted_by);

// The sessions that `selectors` name (session names or shell-style globs,
// fnmatch) or, with `all`, every session; each once, in name order.
// INVALID_ARGUMENT for neither or both, or an empty or over-long selector;
// NOT_FOUND naming a selector that matches no session.
absl::StatusOr<std::vector<std::string>> SelectSessions(
    store::Store& store, const std::vector<std::string>& selectors, bool all);

struct BatchSubmission {
  std::vector<store::JobRecord> jobs;
  std::vector<std::pair<std::string, std::string>> skipped;  // session, why
};

// SubmitProcessing for every selected session. The steps are checked once
// (INVALID_ARGUMENT fails the whole batch); a session that cannot be
// processed (no complete stereo capture, ...) is skipped with the reason.
absl::StatusOr<BatchSubmission> SubmitProcessingBatch(
    JobEngine& engine, const hardware::Rig& rig,
    const ProcessingEnvironment& environment,
    const v1::SubmitProcessingBatchRequest& request,
    absl::string_view submitted_by);

// The job runner for processing jobs (JobKind::kProcessing).
absl::Status RunProcessingJob(const hardware::Rig& rig,
                              const ProcessingEnvironment& environment,
                              JobContext& context);

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_PROCESSING_JOB_H_
