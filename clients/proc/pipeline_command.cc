// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc pipeline --session-dir DIR [--steps a,b] [--force]
//                         [--threads N] [--matching-width W]
//                         [--job-dir DIR/jobs/ID]
// Runs the session pipeline (processing/pipeline/pipeline.h) on a session
// folder without the daemon: frames are found from the capture layout on
// disk, what earlier runs produced is remembered in
// DIR/pipeline_state.json. Prints progress on stderr and the metrics table
// (the thesis' Table 5.2 for this session) on stdout. Says on stderr how
// much memory it expected to need (pipeline/memory_estimate.h) and how much
// it took (the process's maximum resident set).
//
// With --job-dir it is the daemon's unit of remote work (a Slurm batch
// job): the frames, steps and force flag come from the job's request.json
// (frames checked against the sha256 recorded at capture), and the outcome
// goes to the job's result.json, success or not. It never opens SQLite.
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "clients/proc/command_registry.h"
#include "processing/base/status_macros.h"
#include "processing/pipeline/memory_estimate.h"
#include "processing/pipeline/pipeline.h"
#include "processing/pipeline/session_files.h"

namespace hdrstereo::proc {
namespace {

struct PipelineArgs {
  std::string session_dir;
  std::vector<std::string> steps;
  bool force = false;
  int threads = 2;
  std::optional<int> matching_width;
  std::string job_dir;
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
  void StepComputed(const std::string& step, absl::Duration took) override {
    seconds_[step] = absl::ToDoubleSeconds(took);
    std::cerr << absl::StreamFormat("%s: computed in %.2f s\n", step,
                                    seconds_[step]);
  }

  // How long each computed step took.
  const std::map<std::string, double>& seconds() const { return seconds_; }

 private:
  std::map<std::string, double> seconds_;
};

// The run itself; `input` and the steps are the caller's choice.
absl::StatusOr<pipeline::RunSummary> RunOn(const pipeline::SessionInput& input,
                                           pipeline::RunOptions options,
                                           pipeline::JsonRunStore& store,
                                           PrintingObserver& observer) {
  // Only a session with stereo frames has a shape; Run says what is missing
  // otherwise.
  absl::StatusOr<pipeline::RunShape> shape = pipeline::ShapeOfSession(input);
  if (shape.ok()) {
    ASSIGN_OR_RETURN(const pipeline::MemoryEstimate estimate,
                     pipeline::EstimateMemory(*shape, options));
    std::cerr << "memory: estimated " << estimate.Describe(*shape) << "\n";
  }
  ASSIGN_OR_RETURN(pipeline::RunSummary summary,
                   pipeline::Run(input, options, store, observer));
  std::cerr << "computed: " << absl::StrJoin(summary.computed, ", ")
            << "\nreused: " << absl::StrJoin(summary.reused, ", ") << "\n";
  struct rusage usage {};
  if (::getrusage(RUSAGE_SELF, &usage) == 0) {
    std::cerr << "memory: peak resident "
              << pipeline::FormatBytes(static_cast<int64_t>(usage.ru_maxrss) *
                                       1024)
              << " (" << usage.ru_maxrss << " kB)\n";
  }
  if (!summary.report_path.empty()) {
    std::cerr << "report: "
              << (input.session_dir / summary.report_path).string() << "\n";
  }
  if (!summary.metrics.empty()) {
    std::cout << pipeline::FormatMetrics(summary.metrics);
  }
  return summary;
}

absl::Status RunPipeline(const PipelineArgs& args) {
  ASSIGN_OR_RETURN(pipeline::SessionInput input,
                   pipeline::DiscoverSession(args.session_dir));
  ASSIGN_OR_RETURN(
      pipeline::JsonRunStore store,
      pipeline::JsonRunStore::Open(input.session_dir / "pipeline_state.json"));
  pipeline::RunOptions options;
  options.steps = args.steps;
  options.force = args.force;
  options.threads = args.threads;
  if (args.matching_width) {
    options.step_options.experiment.matching_width = *args.matching_width;
  }
  PrintingObserver observer;
  return RunOn(input, options, store, observer).status();
}

// The records of every step the run went through, for the daemon.
absl::StatusOr<pipeline::JobResult> ResultOf(
    const pipeline::RunSummary& summary, const pipeline::JsonRunStore& store,
    const PrintingObserver& observer) {
  pipeline::JobResult result;
  for (const auto* steps : {&summary.computed, &summary.reused}) {
    for (const std::string& step : *steps) {
      auto entry = store.Entry(step);
      if (!entry) {
        return absl::InternalError(
            absl::StrCat("step ", step, " ran but left no record"));
      }
      const auto seconds = observer.seconds().find(step);
      result.steps.push_back(
          {.step = step,
           .input_hash = entry->first,
           .computed = steps == &summary.computed,
           .artifacts = entry->second,
           .seconds = seconds == observer.seconds().end()
                          ? std::nullopt
                          : std::optional<double>(seconds->second)});
    }
  }
  return result;
}

absl::Status RunJob(const PipelineArgs& args) {
  const std::filesystem::path session_dir =
      std::filesystem::absolute(args.session_dir);
  const std::filesystem::path job_dir = args.job_dir;
  auto run = [&]() -> absl::StatusOr<pipeline::JobResult> {
    ASSIGN_OR_RETURN(pipeline::JobRequest request,
                     pipeline::ReadJobRequest(job_dir, session_dir));
    RETURN_IF_ERROR(pipeline::VerifyFrames(request.input));
    ASSIGN_OR_RETURN(
        pipeline::JsonRunStore store,
        pipeline::JsonRunStore::Open(session_dir / "pipeline_state.json"));
    pipeline::RunOptions options;
    options.steps = request.steps;
    options.force = request.force;
    options.threads = args.threads;
    PrintingObserver observer;
    ASSIGN_OR_RETURN(pipeline::RunSummary summary,
                     RunOn(request.input, options, store, observer));
    return ResultOf(summary, store, observer);
  };
  absl::StatusOr<pipeline::JobResult> result = run();
  pipeline::JobResult written = result.ok()
                                    ? *std::move(result)
                                    : pipeline::JobResult{result.status(), {}};
  RETURN_IF_ERROR(pipeline::WriteJobResult(job_dir, written));
  return written.status;
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
  cmd->add_option(
      "--matching-width", args->matching_width,
      absl::StrCat("Match and fuse pairs wider than this at this "
                   "width (pixels; 0 = always at full size) "
                   "[default: ",
                   experiment::ExperimentOptions().matching_width, "]"));
  cmd->add_option("--job-dir", args->job_dir,
                  "Run the daemon's job whose request.json is in this folder "
                  "(steps and force come from it); write its result.json")
      ->check(CLI::ExistingDirectory);
  cmd->callback([args] {
    if (!args->job_dir.empty() && (!args->steps.empty() || args->force)) {
      SetOutcome(absl::InvalidArgumentError(
          "--steps and --force come from the job's request with --job-dir"));
      return;
    }
    if (!args->job_dir.empty() && args->matching_width) {
      // The daemon processes in its own process at the default width too.
      SetOutcome(absl::InvalidArgumentError(
          "--matching-width cannot be used with --job-dir: the daemon's jobs "
          "match at the default width"));
      return;
    }
    SetOutcome(args->job_dir.empty() ? RunPipeline(*args) : RunJob(*args));
  });
}

const CommandGroup kGroup("pipeline", &AddPipelineCommands);

}  // namespace
}  // namespace hdrstereo::proc
