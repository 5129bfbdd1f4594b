// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc pipeline --session-dir DIR [--steps a,b] [--force]
//                         [--threads N]
// Runs the session pipeline (processing/pipeline/pipeline.h) on a session
// folder without the daemon: frames are found from the capture layout on
// disk, what earlier runs produced is remembered in
// DIR/pipeline_state.json. Prints progress on stderr and the metrics table
// (the thesis' Table 5.2 for this session) on stdout.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "processing/pipeline/pipeline.h"
#include "processing/pipeline/session_files.h"
#include "clients/proc/command_registry.h"

namespace hdrstereo::proc {
namespace {

struct PipelineArgs {
  std::string session_dir;
  std::vector<std::string> steps;
  bool force = false;
  int threads = 2;
};

class PrintingObserver : public pipeline::RunObserver {
 public:
  absl::Status Checkpoint() override { return absl::OkStatus(); }
  void Progress(int64_t done, int64_t total, const std::string& what) override {
    std::cerr << "[" << done << "/" << total << "] " << what << "\n";
  }
  void Info(const std::string& message) override {
    std::cerr << message << "\n";
  }
  void Warn(const std::string& message) override {
    std::cerr << "warning: " << message << "\n";
  }
};

absl::Status RunPipeline(const PipelineArgs& args) {
  absl::StatusOr<pipeline::SessionInput> input =
      pipeline::DiscoverSession(args.session_dir);
  if (!input.ok()) return input.status();
  absl::StatusOr<pipeline::JsonRunStore> store =
      pipeline::JsonRunStore::Open(input->session_dir / "pipeline_state.json");
  if (!store.ok()) return store.status();
  PrintingObserver observer;
  pipeline::RunOptions options;
  options.steps = args.steps;
  options.force = args.force;
  options.threads = args.threads;
  absl::StatusOr<pipeline::RunSummary> summary =
      pipeline::Run(*input, options, *store, observer);
  if (!summary.ok()) return summary.status();
  std::cerr << "computed: " << absl::StrJoin(summary->computed, ", ")
            << "\nreused: " << absl::StrJoin(summary->reused, ", ") << "\n";
  if (!summary->report_path.empty()) {
    std::cerr << "report: "
              << (input->session_dir / summary->report_path).string() << "\n";
  }
  if (!summary->metrics.empty()) {
    std::cout << pipeline::FormatMetrics(summary->metrics);
  }
  return absl::OkStatus();
}

void AddPipelineCommands(CLI::App& app) {
  auto args = std::make_shared<PipelineArgs>();
  CLI::App* cmd = app.add_subcommand(
      "pipeline",
      "Process a session folder: HDR, tone mapping, stereo, fusion, "
      "structured-light truth, metrics, Middlebury export, HTML report");
  cmd->add_option("--session-dir", args->session_dir, "Session folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--steps", args->steps,
                  absl::StrCat("Steps to run (their dependencies are added): ",
                               absl::StrJoin(pipeline::AllSteps(), ",")))
      ->delimiter(',');
  cmd->add_flag("--force", args->force, "Recompute even when unchanged");
  cmd->add_option("--threads", args->threads, "Worker threads")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->callback([args] { SetOutcome(RunPipeline(*args)); });
}

const CommandGroup kGroup("pipeline", &AddPipelineCommands);

}  // namespace
}  // namespace hdrstereo::proc
