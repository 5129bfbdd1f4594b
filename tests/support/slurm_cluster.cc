// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/slurm_cluster.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "processing/base/status_macros.h"
#include "tests/support/free_ports.h"

namespace hdrstereo::testing {
namespace fs = std::filesystem;

namespace {

constexpr const char* kMunged = "/usr/sbin/munged";
constexpr const char* kSlurmctld = "/usr/sbin/slurmctld";
constexpr const char* kSlurmd = "/usr/sbin/slurmd";
constexpr const char* kSbatch = "/usr/bin/sbatch";

int64_t MemoryMb() {
  return static_cast<int64_t>(::sysconf(_SC_PHYS_PAGES)) *
         ::sysconf(_SC_PAGESIZE) / (1024 * 1024) * 8 / 10;
}

std::string Tail(const fs::path& path, size_t bytes) {
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)),
                   std::istreambuf_iterator<char>());
  return text.size() > bytes ? text.substr(text.size() - bytes) : text;
}

}  // namespace

std::optional<std::string> SlurmCluster::SkipReason() {
  std::optional<std::string> reason = SkipReasonHere();
  // CI must run these tests: there a missing cluster fails them.
  if (reason && std::getenv("HDRSTEREO_REQUIRE_SLURM") != nullptr) {
    ADD_FAILURE() << "HDRSTEREO_REQUIRE_SLURM is set but " << *reason;
    return std::nullopt;
  }
  return reason;
}

std::optional<std::string> SlurmCluster::SkipReasonHere() {
  if (::geteuid() != 0) {
    return "the single-node Slurm cluster needs root (slurmd runs jobs as "
           "their user); .ci/run runs as root";
  }
  for (const char* tool : {kMunged, kSlurmctld, kSlurmd, kSbatch}) {
    if (!fs::exists(tool)) {
      return absl::StrCat(tool,
                          " is absent: install slurm-wlm and munge "
                          "(deploy/setup-deps.sh)");
    }
  }
  return std::nullopt;
}

absl::StatusOr<std::unique_ptr<SlurmCluster>> SlurmCluster::Start(
    absl::Duration timeout) {
  constexpr int kAttempts = 3;
  absl::StatusOr<std::unique_ptr<SlurmCluster>> cluster;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    cluster = StartOnce(timeout);
    if (!absl::IsAborted(cluster.status())) break;
  }
  return cluster;
}

absl::StatusOr<std::unique_ptr<SlurmCluster>> SlurmCluster::StartOnce(
    absl::Duration timeout) {
  std::unique_ptr<SlurmCluster> c(new SlurmCluster());
  const fs::path& t = c->dir_.path();
  ::chmod(t.c_str(), 0755);  // munged checks every folder above its socket
  for (const char* sub : {"munge", "state", "spool", "log"}) {
    fs::create_directories(t / sub);
  }
  // A private key: the cluster never authenticates with the system's munge.
  {
    std::random_device random;
    std::string key(1024, '\0');
    for (char& ch : key) ch = static_cast<char>(random());
    std::ofstream(t / "munge/key", std::ios::binary) << key;
    ::chmod((t / "munge/key").c_str(), 0400);
  }
  const fs::path socket = t / "munge/socket";
  ASSIGN_OR_RETURN(
      Process munged,
      Process::Start(
          {kMunged, "--foreground",
           absl::StrCat("--key-file=", (t / "munge/key").string()),
           absl::StrCat("--socket=", socket.string()),
           absl::StrCat("--pid-file=", (t / "munge/pid").string()),
           absl::StrCat("--seed-file=", (t / "munge/seed").string()),
           absl::StrCat("--log-file=", (t / "log/munged.log").string())},
          t / "log/munged.out"));
  c->daemons_.push_back(std::move(munged));
  if (!WaitForSocket(socket, absl::Seconds(10))) {
    return absl::DeadlineExceededError(absl::StrCat(
        "munged did not create its socket in 10 s: ", c->LogTails()));
  }

  ASSIGN_OR_RETURN(std::vector<int> ports, FreeLoopbackPorts(2));
  const int ctld_port = ports[0];
  const int slurmd_port = ports[1];
  c->cpus_ = static_cast<int>(std::thread::hardware_concurrency());
  c->conf_ = t / "slurm.conf";
  std::ofstream(c->conf_)
      << "ClusterName=hdrstereo-test\n"
      << "SlurmctldHost=localhost\n"
      << "SlurmUser=root\nSlurmdUser=root\n"
      << "AuthInfo=socket=" << socket.string() << "\n"
      << "SlurmctldPort=" << ctld_port << "\nSlurmdPort=" << slurmd_port << "\n"
      << "StateSaveLocation=" << (t / "state").string() << "\n"
      << "SlurmdSpoolDir=" << (t / "spool").string() << "\n"
      << "SlurmctldPidFile=" << (t / "slurmctld.pid").string() << "\n"
      << "SlurmdPidFile=" << (t / "slurmd.pid").string() << "\n"
      << "SlurmctldLogFile=" << (t / "log/slurmctld.log").string() << "\n"
      << "SlurmdLogFile=" << (t / "log/slurmd.log").string() << "\n"
      << "ProctrackType=proctrack/pgid\nTaskPlugin=task/none\n"
      << "SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n"
      << "AccountingStorageType=accounting_storage/none\n"
      << "JobAcctGatherType=jobacct_gather/none\nMpiDefault=none\n"
      << "ReturnToService=2\nMinJobAge=600\n"
      << "NodeName=localhost NodeAddr=127.0.0.1 CPUs=" << c->cpus_
      << " RealMemory=" << MemoryMb() << " State=UNKNOWN\n"
      << "PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE "
         "State=UP\n";
  for (std::vector<std::string> argv :
       {std::vector<std::string>{kSlurmctld, "-D", "-i", "-f",
                                 c->conf_.string()},
        std::vector<std::string>{kSlurmd, "-D", "-f", c->conf_.string(), "-N",
                                 "localhost"}}) {
    ASSIGN_OR_RETURN(
        Process daemon,
        Process::Start(
            argv,
            t / "log" /
                absl::StrCat(fs::path(argv[0]).filename().string(), ".out")));
    c->daemons_.push_back(std::move(daemon));
  }
  const absl::Time deadline = absl::Now() + timeout;
  std::string last;
  while (absl::Now() < deadline) {
    absl::StatusOr<CommandResult> sinfo =
        c->Run({"sinfo", "-h", "-N", "-o", "%T"}, absl::Seconds(10));
    if (sinfo.ok()) {
      last = sinfo->out + sinfo->err;
      if (absl::StartsWith(sinfo->out, "idle")) {
        c->up_ = true;
        return c;
      }
    }
    if (c->PortTaken()) {
      return absl::AbortedError(absl::StrCat(
          "another process took a Slurm port before its daemon bound it; ",
          c->LogTails()));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  return absl::DeadlineExceededError(absl::StrCat(
      "the Slurm node was not idle within ", absl::FormatDuration(timeout),
      " (sinfo: \"", last, "\"); ", c->LogTails()));
}

SlurmCluster::~SlurmCluster() {
  // Jobs a failed test left behind end with the cluster, not after it.
  if (up_) {
    Run({"scancel", "--partition=test"}).IgnoreError();
  }
  // slurmd first, munged last.
  for (auto it = daemons_.rbegin(); it != daemons_.rend(); ++it) {
    it->Signal(SIGTERM);
    if (!it->Wait(absl::Seconds(15))) {
      it->Signal(SIGKILL);
      it->Wait(absl::Seconds(5));
    }
  }
}

absl::StatusOr<CommandResult> SlurmCluster::Run(std::vector<std::string> argv,
                                                absl::Duration timeout) {
  argv.insert(argv.begin(),
              {"/usr/bin/env", absl::StrCat("SLURM_CONF=", conf_.string())});
  return RunCommand(argv, timeout);
}

bool SlurmCluster::PortTaken() const {
  for (const char* log : {"slurmctld.log", "slurmd.log"}) {
    if (absl::StrContains(Tail(dir_.path() / "log" / log, 64 * 1024),
                          "Address already in use")) {
      return true;
    }
  }
  return false;
}

std::string SlurmCluster::LogTails() const {
  std::string out;
  for (const char* log : {"munged.log", "munged.out", "slurmctld.log",
                          "slurmctld.out", "slurmd.log", "slurmd.out"}) {
    absl::StrAppend(&out, "\n--- ", log, ":\n",
                    Tail(dir_.path() / "log" / log, 1500));
  }
  return out;
}

}  // namespace hdrstereo::testing
