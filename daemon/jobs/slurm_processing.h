// SPDX-License-Identifier: GPL-3.0-or-later
//
// A processing job run as one Slurm batch job (--processing-backend
// slurm): the request goes to the job's folder on the shared data root,
// `sbatch` runs `hdrstereo-proc pipeline --job-dir` on a node, and the
// daemon follows the batch job with squeue while it is queued or running,
// then sacct where the cluster keeps accounting, else scontrol, until the
// run's result.json says how it went. The daemon never
// trusts the node's word alone: every artifact's sha256 is checked before
// the caller records it.
#ifndef HDRSTEREO_DAEMON_JOBS_SLURM_PROCESSING_H_
#define HDRSTEREO_DAEMON_JOBS_SLURM_PROCESSING_H_

#include "absl/status/statusor.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/processing/slurm_cli.h"
#include "processing/pipeline/session_files.h"

namespace hdrstereo::slurm {

// Submits `request` for the job of `context` (writing the job's folder
// first), or re-attaches to the batch job it already has (after a daemon
// restart), and waits for it to end. Events: the submission, every change
// of Slurm's state ("PENDING (Priority)", "RUNNING on node c12"), and the
// run's progress from its log. Returns the run's result once its artifacts
// are verified (DATA_LOSS otherwise). A run that failed returns its own
// status and message; a batch job that ended without a result (killed,
// cancelled on the cluster, out of time) is UNAVAILABLE with Slurm's state
// and reason and the tail of the job's log; one whose result is refused
// (pipeline::ReadJobResult's DATA_LOSS: damaged, or naming a file outside
// the session) is DATA_LOSS "Slurm job N ended STATE; its result was
// refused: <why>". A Slurm tool that fails is UNAVAILABLE quoting the last
// 2000 bytes of its stderr and stdout (QuoteInputTail). A cancelled job is
// scancelled (CANCELLED); when the daemon stops (ABORTED) the batch job is
// left to run and the next start re-attaches. A controller that cannot be
// reached suspends the job until it answers again.
absl::StatusOr<pipeline::JobResult> RunOnSlurm(
    const SlurmOptions& options, const pipeline::JobRequest& request,
    jobs::JobContext& context);

}  // namespace hdrstereo::slurm

#endif  // HDRSTEREO_DAEMON_JOBS_SLURM_PROCESSING_H_
