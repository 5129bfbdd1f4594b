// SPDX-License-Identifier: GPL-3.0-or-later
//
// The scheduler and the cache: runs the step table's steps in dependency
// order on a few threads, skips a step whose input hash (its name, the
// pipeline version, its configured parameters and the sha256 of every file
// it reads) matches what the RunStore recorded and whose files are intact,
// and writes a manifest for every computed step.
#include "processing/pipeline/pipeline.h"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "processing/base/options.h"
#include "processing/base/status_macros.h"
#include "processing/io/image.h"
#include "processing/io/sha256.h"
#include "processing/pipeline/frame_selection.h"
#include "processing/pipeline/session_files.h"
#include "processing/pipeline/step.h"

namespace hdrstereo::pipeline {
namespace fs = std::filesystem;
namespace {

// Part of every input hash: bump when a step's outputs change meaning.
constexpr char kVersion[] = "hdrstereo-pipeline-2";

const StepSpec& SpecOf(const std::string& step) {
  for (const StepSpec& s : StepTable()) {
    if (s.name == step) return s;
  }
  // ResolveSteps only returns names of the table.
  return StepTable().front();
}

class Runner {
 public:
  Runner(RunSession session, RunStore& store, RunObserver& observer)
      : session_(std::move(session)), state_(store, observer) {}

  // Runs `steps` (topologically ordered); the first error stops the run.
  absl::Status Schedule(const std::vector<std::string>& steps);
  std::vector<std::string> computed() ABSL_LOCKS_EXCLUDED(computed_mu_) {
    absl::MutexLock l(&computed_mu_);
    return computed_;
  }

 private:
  absl::Status ExecuteStep(const StepSpec& spec);
  // Path and sha256 of every file `spec` reads.
  absl::StatusOr<std::vector<std::pair<std::string, std::string>>> InputsOf(
      const StepSpec& spec) const;
  bool Verified(const std::vector<Artifact>& artifacts) const;

  const RunSession session_;
  RunState state_;
  absl::Mutex computed_mu_;
  std::vector<std::string> computed_ ABSL_GUARDED_BY(computed_mu_);
};

absl::StatusOr<std::vector<std::pair<std::string, std::string>>>
Runner::InputsOf(const StepSpec& spec) const {
  std::vector<std::pair<std::string, std::string>> out;
  auto add = [&](const std::string& rel,
                 const std::string& what) -> absl::Status {
    absl::StatusOr<std::string> sha = io::Sha256HexOfFile(session_.dir / rel);
    if (!sha.ok()) {
      return absl::FailedPreconditionError(
          absl::StrCat(what, " ", rel, ": ", sha.status().message()));
    }
    out.emplace_back(rel, *sha);
    return absl::OkStatus();
  };
  const FrameSelection& frames = session_.frames;
  switch (spec.inputs) {
    case StepInputs::kStereoFrames:
    case StepInputs::kCalibrationFrames:
      for (int v = 0; v < 2; ++v) {
        for (const FrameInput& f : spec.inputs == StepInputs::kStereoFrames
                                       ? frames.stereo[v]
                                       : frames.calibration[v]) {
          RETURN_IF_ERROR(add(f.path, "frame"));
        }
      }
      break;
    case StepInputs::kStructuredLightFrames:
      for (const FrameInput& f : frames.structured_light) {
        RETURN_IF_ERROR(add(f.path, "frame"));
      }
      break;
    case StepInputs::kSimulatorTruth:
      for (const std::string& rel : {session_.input.sim_truth_disparity,
                                     session_.input.sim_truth_nonoccluded}) {
        if (!rel.empty()) RETURN_IF_ERROR(add(rel, "simulator truth"));
      }
      break;
    case StepInputs::kNone:
      break;
  }
  for (const std::string& dep : spec.deps) {
    for (const Artifact& a : state_.OutputsOf(dep)) {
      // Manifests name the upstream input hash, which may change while the
      // files do not.
      if (a.kind != "manifest") out.emplace_back(a.path, a.sha256);
    }
  }
  return out;
}

bool Runner::Verified(const std::vector<Artifact>& artifacts) const {
  if (artifacts.empty()) return false;
  for (const Artifact& a : artifacts) {
    absl::StatusOr<std::string> sha =
        io::Sha256HexOfFile(session_.dir / a.path);
    if (!sha.ok() || *sha != a.sha256) return false;
  }
  return true;
}

absl::Status Runner::ExecuteStep(const StepSpec& spec) {
  const std::string step = spec.name;
  RETURN_IF_ERROR(state_.Checkpoint());
  const absl::Time start = absl::Now();
  ASSIGN_OR_RETURN(const auto inputs, InputsOf(spec));
  // The step's options, built once: hashed here, used by `run` below.
  StepContext context(session_, state_, step, "");
  ASSIGN_OR_RETURN(const ConfiguredStep configured, spec.configure(context));
  // Text that is not UTF-8 is replaced, not thrown on (a worker thread).
  const std::string params = configured.params.dump(
      -1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string key = absl::StrCat(step, "\n", kVersion, "\n", params, "\n");
  for (const auto& [path, sha] : inputs) {
    absl::StrAppend(&key, path, " ", sha, "\n");
  }
  const std::string hash = io::Sha256Hex(key);

  if (!session_.options.force) {
    std::vector<Artifact> earlier = state_.Lookup(step, hash);
    if (Verified(earlier)) {
      state_.Info(absl::StrCat(step, ": unchanged, reused"));
      state_.SetOutputs(step, std::move(earlier));
      return absl::OkStatus();
    }
  }

  state_.Info(absl::StrCat(step, ": computing"));
  StepContext run(session_, state_, step, params);
  try {
    RETURN_IF_ERROR(configured.run(run));
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat(step, ": OpenCV: ", e.what()));
  }

  // The manifest: what the step read and wrote, so that a step without
  // outputs (no structured light) is remembered too.
  std::vector<Artifact>& outputs = run.outputs().artifacts();
  for (Artifact& a : outputs) {
    ASSIGN_OR_RETURN(a.sha256, io::Sha256HexOfFile(session_.dir / a.path));
    std::error_code ec;
    a.size_bytes =
        static_cast<int64_t>(fs::file_size(session_.dir / a.path, ec));
  }
  const std::string manifest =
      StepManifestJson(step, hash, configured.params, outputs);
  RETURN_IF_ERROR(run.outputs().WriteText(
      "manifest", absl::StrCat("pipeline/", step, ".json"), manifest));
  Artifact& m = outputs.back();
  m.sha256 = io::Sha256Hex(manifest);
  m.size_bytes = static_cast<int64_t>(manifest.size());
  RETURN_IF_ERROR(state_.Record(step, hash, outputs));
  state_.SetOutputs(step, std::move(outputs));
  state_.StepComputed(step, absl::Now() - start);
  absl::MutexLock l(&computed_mu_);
  computed_.push_back(step);
  return absl::OkStatus();
}

absl::Status Runner::Schedule(const std::vector<std::string>& steps) {
  absl::Mutex mu;
  absl::CondVar finished;  // a step is done or failed
  std::set<std::string> done, started;
  int running = 0;
  absl::Status first;
  std::vector<std::thread> threads;
  const int max_running = std::max(1, session_.options.threads);
  {
    absl::MutexLock lock(&mu);
    for (;;) {
      if (first.ok()) {
        for (const std::string& step : steps) {
          if (running >= max_running) break;
          if (started.count(step)) continue;
          const StepSpec& spec = SpecOf(step);
          if (!std::all_of(
                  spec.deps.begin(), spec.deps.end(),
                  [&](const std::string& d) { return done.count(d) > 0; })) {
            continue;
          }
          started.insert(step);
          ++running;
          threads.emplace_back([&, step] {
            absl::Status s = ExecuteStep(SpecOf(step));
            absl::MutexLock l(&mu);
            if (s.ok()) {
              done.insert(step);
            } else if (first.ok()) {
              first = s;
            }
            --running;
            finished.SignalAll();
          });
        }
      }
      if (running == 0) break;
      finished.Wait(&mu);
    }
  }
  for (std::thread& t : threads) t.join();
  return first;
}

}  // namespace

std::string StepManifestJson(const std::string& step,
                             const std::string& input_hash,
                             const nlohmann::json& params,
                             const std::vector<Artifact>& outputs) {
  nlohmann::json files = nlohmann::json::array();
  for (const Artifact& a : outputs) {
    files.push_back(nlohmann::json{{"path", a.path}, {"sha256", a.sha256}});
  }
  const nlohmann::json manifest = {{"step", step},
                                   {"version", kVersion},
                                   {"input_hash", input_hash},
                                   {"params", params},
                                   {"outputs", files}};
  return manifest.dump(2, ' ', false,
                       nlohmann::json::error_handler_t::replace) +
         "\n";
}

absl::Status StepOptions::Validate() const {
  RETURN_IF_ERROR(WithFieldPrefix("experiment", experiment.Validate()));
  RETURN_IF_ERROR(WithFieldPrefix("sl_decode", sl_decode.Validate()));
  return WithFieldPrefix("sl_ground_truth", sl_ground_truth.Validate());
}

absl::StatusOr<RunSummary> Run(const SessionInput& input,
                               const RunOptions& options, RunStore& store,
                               RunObserver& observer) {
  ASSIGN_OR_RETURN(const std::vector<std::string> steps,
                   ResolveSteps(options.steps));
  RETURN_IF_ERROR(options.step_options.Validate());
  ASSIGN_OR_RETURN(FrameSelection frames, SelectFrames(input));
  RETURN_IF_ERROR(CheckSelection(frames, input, steps));
  observer.Info(absl::StrCat("steps: ", absl::StrJoin(steps, ", ")));

  Runner runner(
      RunSession{input, input.session_dir, std::move(frames), options}, store,
      observer);
  RETURN_IF_ERROR(runner.Schedule(steps));

  RunSummary summary;
  const std::vector<std::string> computed = runner.computed();
  for (const std::string& step : steps) {
    (std::find(computed.begin(), computed.end(), step) != computed.end()
         ? summary.computed
         : summary.reused)
        .push_back(step);
  }
  if (std::find(steps.begin(), steps.end(), "evaluate") != steps.end()) {
    ASSIGN_OR_RETURN(summary.metrics,
                     ReadMetricsFile(input.session_dir / kMetricsFile));
  }
  if (std::find(steps.begin(), steps.end(), "report") != steps.end()) {
    summary.report_path = "report/index.html";
  }
  return summary;
}

}  // namespace hdrstereo::pipeline
