// SPDX-License-Identifier: GPL-3.0-or-later
// What Slurm's tools print (sbatch --parsable, squeue, scontrol, sacct).
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
  return 0;
}
