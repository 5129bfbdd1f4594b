// SPDX-License-Identifier: GPL-3.0-or-later
// What Slurm's tools print (sbatch --parsable, squeue, scontrol, sacct),
// and the progress lines of a job's log on the shared file system.
#include "daemon/processing/slurm_cli.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

void CheckState(const absl::StatusOr<hdrstereo::slurm::JobState>& state) {
  if (!state.ok()) return;
  FUZZ_CHECK(!hdrstereo::slurm::Describe(*state).empty());
  (void)hdrstereo::slurm::IsFinal(state->state);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace slurm = hdrstereo::slurm;
  const absl::string_view out = hdrstereo::fuzz::AsText(data, size);
  absl::StatusOr<int64_t> id = slurm::ParseSbatchOutput(out);
  FUZZ_CHECK(!id.ok() || *id > 0);
  // The recorded outputs in the corpus (tests/unit/slurm/testdata) are of
  // job 4.
  constexpr int64_t kJob = 4;
  CheckState(slurm::ParseSqueueOutput(out, kJob));
  CheckState(slurm::ParseScontrolOutput(out, kJob));
  CheckState(slurm::ParseSacctOutput(out, kJob));
  // The same bytes as the tail of a job's log.
  const std::optional<slurm::LogProgress> progress = slurm::LastProgress(out);
  FUZZ_CHECK(!progress || (progress->done >= 0 && progress->total >= 0 &&
                           progress->what.size() <= slurm::kMaxFieldBytes));
  return 0;
}
