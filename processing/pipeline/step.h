// SPDX-License-Identifier: GPL-3.0-or-later
//
// The contract between the pipeline's scheduler (pipeline.cc) and its
// steps (the *_steps.cc files, one per stage): a step is one row of the
// step table (step_table.cc) that names it, its dependencies and what it
// reads from the session, and a Configure function that builds the step's
// options once and returns both their canonical JSON (part of the cache
// key) and the run that uses exactly those options. Steps read the files of
// the steps before them through StepContext and write theirs through
// StepOutputs, which records every file as an artifact.
#ifndef HDRSTEREO_PROCESSING_PIPELINE_STEP_H_
#define HDRSTEREO_PROCESSING_PIPELINE_STEP_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "processing/hdr/stack.h"
#include "processing/pipeline/frame_selection.h"
#include "processing/pipeline/pipeline.h"

namespace hdrstereo::pipeline {

// Files the steps share by name.
inline constexpr char kMetricsFile[] = "metrics/metrics.json";
inline constexpr char kStructuredLightDir[] = "ground_truth/structured_light";

// A ground truth the steps score against.
struct Truth {
  std::string name;     // "structured_light" or "simulation"
  cv::Mat disparity;    // CV_32FC1, +inf unknown
  cv::Mat nonoccluded;  // CV_8UC1, 255 = scored
  cv::Mat mask0nocc;    // Middlebury mask (processing/io/middlebury.h)
};

// The files a step (or one unit of a step) wrote, relative to the session
// folder, in the order written. Each is written atomically.
class StepOutputs {
 public:
  StepOutputs(std::filesystem::path session_dir, std::string step,
              std::string params)
      : dir_(std::move(session_dir)),
        step_(std::move(step)),
        params_(std::move(params)) {}

  // Creates the folder of `rel`, writes it with `write` and records it.
  absl::Status Write(
      const std::string& kind, const std::string& rel,
      const std::function<absl::Status(const std::filesystem::path&)>& write);
  // io::WriteImage (by extension) and text.
  absl::Status WriteImage(const std::string& kind, const std::string& rel,
                          const cv::Mat& image);
  absl::Status WriteText(const std::string& kind, const std::string& rel,
                         const std::string& text);
  absl::Status CopyFile(const std::string& kind, const std::string& from_rel,
                        const std::string& rel);
  // Records a file written by a library call that writes several.
  void Record(const std::string& kind, const std::string& rel);
  // Appends `other`'s files after these.
  void Append(StepOutputs&& other);
  // No files yet, for the same step (one unit of it).
  StepOutputs Empty() const { return StepOutputs(dir_, step_, params_); }

  const std::filesystem::path& dir() const { return dir_; }
  std::vector<Artifact>& artifacts() { return artifacts_; }

 private:
  std::filesystem::path dir_;
  std::string step_;
  std::string params_;
  std::vector<Artifact> artifacts_;
};

// What the steps of one run share: the caller's store and observer, called
// one at a time from any thread, and the artifacts of the finished steps.
class RunState {
 public:
  RunState(RunStore& store, RunObserver& observer)
      : store_(store), observer_(observer) {}

  absl::Status Checkpoint() ABSL_LOCKS_EXCLUDED(mu_);
  void Progress(int64_t done, int64_t total, const std::string& what)
      ABSL_LOCKS_EXCLUDED(mu_);
  void Info(const std::string& message) ABSL_LOCKS_EXCLUDED(mu_);
  void Warn(const std::string& message) ABSL_LOCKS_EXCLUDED(mu_);
  void StepComputed(const std::string& step, absl::Duration took)
      ABSL_LOCKS_EXCLUDED(mu_);
  std::vector<Artifact> Lookup(const std::string& step,
                               const std::string& input_hash)
      ABSL_LOCKS_EXCLUDED(mu_);
  absl::Status Record(const std::string& step, const std::string& input_hash,
                      const std::vector<Artifact>& artifacts)
      ABSL_LOCKS_EXCLUDED(mu_);
  absl::Status RecordMetrics(const std::vector<Metric>& metrics)
      ABSL_LOCKS_EXCLUDED(mu_);

  // The artifacts of a finished (computed or reused) step.
  void SetOutputs(const std::string& step, std::vector<Artifact> artifacts)
      ABSL_LOCKS_EXCLUDED(outputs_mu_);
  std::vector<Artifact> OutputsOf(const std::string& step) const
      ABSL_LOCKS_EXCLUDED(outputs_mu_);

 private:
  absl::Mutex mu_;  // one call at a time into the caller's objects
  RunStore& store_ ABSL_GUARDED_BY(mu_);
  RunObserver& observer_ ABSL_GUARDED_BY(mu_);
  mutable absl::Mutex outputs_mu_;
  std::map<std::string, std::vector<Artifact>> outputs_
      ABSL_GUARDED_BY(outputs_mu_);
};

// One run's fixed facts: the session, its frames and the options.
struct RunSession {
  const SessionInput& input;
  std::filesystem::path dir;  // input.session_dir
  FrameSelection frames;
  const RunOptions& options;
};

// What a step sees, and where it writes.
class StepContext {
 public:
  StepContext(const RunSession& session, RunState& state,
              const std::string& step, std::string params)
      : session_(session),
        state_(state),
        outputs_(session.dir, step, std::move(params)),
        step_(step) {}

  const SessionInput& input() const { return session_.input; }
  const std::filesystem::path& dir() const { return session_.dir; }
  const FrameSelection& frames() const { return session_.frames; }
  const StepOptions& options() const { return session_.options.step_options; }
  const std::string& step() const { return step_; }
  StepOutputs& outputs() { return outputs_; }
  RunState& state() { return state_; }

  // Files below the session folder.
  absl::StatusOr<cv::Mat> Read(const std::string& rel) const;
  absl::StatusOr<cv::Mat> ReadPfm(const std::string& rel) const;
  // The rectified exposure stack of a view (the rectify step's output).
  absl::StatusOr<hdr::ExposureStack> Stack(int view) const;
  // The LDR exposure: the middle of the stack (longest first).
  size_t LdrIndex() const { return frames().stereo[0].size() / 2; }
  // A view's LDR exposure and its time, without decoding the rest of the
  // stack (the steps that need only it, or only the images' size).
  absl::StatusOr<hdr::StackImage> Ldr(int view) const;

  // The ground truths there are, best first.
  absl::StatusOr<std::vector<Truth>> Truths() const;
  // The disparity range every matching and fusion uses
  // (experiment::DisparityRange of the ground truths), for images `width`
  // wide; `scale` of the images' size when they are matched at a working
  // size.
  absl::StatusOr<int> MaxDisparity(int width, double scale = 1.0) const;

  void Progress(int64_t done, int64_t total, const std::string& what) {
    state_.Progress(done, total, what);
  }
  void Info(const std::string& message) { state_.Info(message); }
  void Warn(const std::string& message) { state_.Warn(message); }

  // Runs fn(i, outputs of unit i) for each name on up to the run's threads
  // (and at most `max_at_once` at once when it is > 0), checking the
  // observer before each unit and reporting progress ("<step>: <name>")
  // after it; the first error stops the rest. The units' files are appended
  // to the step's in unit order (not completion order).
  absl::Status ParallelFor(
      const std::vector<std::string>& names,
      const std::function<absl::Status(int, StepOutputs&)>& fn,
      int max_at_once = 0);
  // ParallelFor for the experiment's units (matchings, fusions), which
  // write nothing themselves.
  experiment::UnitRunner Units();

 private:
  bool HasStructuredLightTruth() const;

  const RunSession& session_;
  RunState& state_;
  StepOutputs outputs_;
  const std::string step_;
};

// A step ready to run with the options it was configured with.
struct ConfiguredStep {
  nlohmann::json params;  // canonical JSON of what `run` uses
  std::function<absl::Status(StepContext&)> run;
};

// What a step reads from the session besides its dependencies' outputs
// (their paths and sha256 are part of its cache key).
enum class StepInputs {
  kNone,
  kStereoFrames,
  kCalibrationFrames,
  kStructuredLightFrames,
  kSimulatorTruth,
};

struct StepSpec {
  const char* name;
  std::vector<std::string> deps;
  StepInputs inputs;
  // Called when the dependencies have finished; builds what the step runs
  // with (the step table lists the Configure* functions of steps.h).
  absl::StatusOr<ConfiguredStep> (*configure)(const StepContext&);
};

// The steps in topological order: the one table the scheduler and the
// cache read. Defined in step_table.cc.
const std::vector<StepSpec>& StepTable();

}  // namespace hdrstereo::pipeline

#endif  // HDRSTEREO_PROCESSING_PIPELINE_STEP_H_
