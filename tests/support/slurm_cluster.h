// SPDX-License-Identifier: GPL-3.0-or-later
//
// A single-node Slurm cluster on 127.0.0.1 for tests, from Debian's
// packages (slurm-wlm, munge; deploy/setup-deps.sh): a private munged (its
// own key and socket, so a system munge, running or not, is left alone), a
// temp slurm.conf (free ports, this machine's CPUs and memory, one
// partition, no accounting; ../shared/recipes/slurm-single-node.md), and
// slurmctld and slurmd in the foreground, so that the fixture owns their
// pids and stops exactly what it started. Needs root (slurmd runs jobs as
// their user).
#ifndef HDRSTEREO_TESTS_SUPPORT_SLURM_CLUSTER_H_
#define HDRSTEREO_TESTS_SUPPORT_SLURM_CLUSTER_H_

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::testing {

class SlurmCluster {
 public:
  // Why the cluster cannot run here (not root, packages absent), or nullopt.
  // With HDRSTEREO_REQUIRE_SLURM set (.ci/run) a reason fails the test.
  static std::optional<std::string> SkipReason();

  // Starts munged, slurmctld and slurmd and waits (at most `timeout`) until
  // sinfo shows the node idle. The error carries the daemons' log tails.
  // A port taken by another process between choosing and binding (tests run
  // in parallel) restarts the cluster on fresh ports, at most three times.
  static absl::StatusOr<std::unique_ptr<SlurmCluster>> Start(
      absl::Duration timeout = absl::Seconds(60));
  ~SlurmCluster();  // SIGTERM, then SIGKILL, to the three daemons it started

  // Runs a Slurm client tool ("sbatch", "squeue", ...) with SLURM_CONF set
  // to this cluster's config.
  absl::StatusOr<CommandResult> Run(std::vector<std::string> argv,
                                    absl::Duration timeout = absl::Seconds(30));
  const std::filesystem::path& conf() const { return conf_; }
  int cpus() const { return cpus_; }

 private:
  SlurmCluster() = default;
  static std::optional<std::string> SkipReasonHere();
  // One try; ABORTED when slurmctld or slurmd found its port taken.
  static absl::StatusOr<std::unique_ptr<SlurmCluster>> StartOnce(
      absl::Duration timeout);
  bool PortTaken() const;
  std::string LogTails() const;

  TempDir dir_;
  std::filesystem::path conf_;
  int cpus_ = 1;
  bool up_ = false;  // the node was idle once: jobs may be left to cancel
  std::vector<Process> daemons_;  // munged, slurmctld, slurmd
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_SLURM_CLUSTER_H_
