// SPDX-License-Identifier: GPL-3.0-or-later
//
// The session pipeline: a small DAG of named steps that turns a captured
// session into HDR images, tone-mapped pairs, disparity maps, their fusion,
// the structured-light ground truth, metrics, a Middlebury-2014 export and
// an HTML report.
//
//   decode -> rectify -> response -> hdr -> tonemap -> stereo -> fusion
//   sl_groundtruth (reads its frames itself) -> stereo, fusion (disparity
//     range), evaluate, export
//   stereo, fusion, sl_groundtruth -> evaluate -> report
//   rectify, sl_groundtruth -> export (Middlebury 2014 layout)
// (the step table, step_table.cc, has the exact edges; docs/pipeline.md
// the files; step.h the contract between the scheduler and the steps.)
//
// The pipeline knows nothing of SQLite or RPC: the caller (the daemon's
// processing job) says which frames exist, remembers what earlier runs
// produced through RunStore, and watches through RunObserver. Every file is
// written atomically under the session folder; nothing outside the steps
// being recomputed is touched, and nothing already computed is deleted when
// a step fails.
#ifndef HDRSTEREO_PROCESSING_PIPELINE_PIPELINE_H_
#define HDRSTEREO_PROCESSING_PIPELINE_PIPELINE_H_

#include <cstdint>
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "processing/experiment/thesis_experiment.h"
#include "processing/io/capture_layout.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/ground_truth.h"

namespace hdrstereo::pipeline {

// Step names in topological order.
const std::vector<std::string>& AllSteps();

// The requested steps plus everything they need, in topological order.
// Empty `requested` = every step. INVALID_ARGUMENT naming an unknown step
// and listing the known ones.
absl::StatusOr<std::vector<std::string>> ResolveSteps(
    const std::vector<std::string>& requested);

// The steps `step` reads outputs of (empty for an unknown step).
const std::vector<std::string>& StepDependencies(const std::string& step);

// One captured frame (the daemon's frame row).
struct FrameInput {
  std::string path;  // relative to the session folder
  io::CaptureKind capture_kind = io::CaptureKind::kBracketedStereo;
  int64_t capture_id = 0;
  // The folder below the view in the capture layout.
  io::FrameRole role = io::FrameRole::kStereo;
  int view_index = 0;  // 0 = left (the reference view), 1 = right
  double exposure_s = 0;
  std::string pattern;  // structured light: "col_b03", "white", ...; else ""
  bool inverse = false;
  std::string sha256;
};

struct SessionInput {
  std::filesystem::path session_dir;  // absolute; every output goes below
  std::string session_name;
  std::vector<FrameInput> frames;  // in capture order
  double baseline_mm = 0;          // of the stereo capture used
  std::optional<std::pair<int, int>> projector_size;  // width, height
  // Shown first in the report's capture summary, in this order (hardware,
  // timings, ...).
  std::vector<std::pair<std::string, std::string>> capture_summary;
  // Exact truth written at capture time in simulation (relative paths;
  // empty = none): left-view disparity PFM (+inf = no truth) and a PNG
  // mask, 255 = visible in both views.
  std::string sim_truth_disparity;
  std::string sim_truth_nonoccluded;
  // Rectified pinhole intrinsics of the stereo views in pixels, for the
  // export's calib.txt; when unset the calib.txt beside the simulator truth
  // is used, else a nominal camera (see docs/pipeline.md).
  struct Intrinsics {
    double fx = 0, fy = 0, cx = 0, cy = 0;
  };
  std::optional<Intrinsics> intrinsics;
  // The rig's latest calibration (calib::SaveCalibration YAML, absolute
  // path; empty = none) and how the report names it: rectification uses it
  // when the session has no calibration capture of its own.
  std::filesystem::path rig_calibration;
  std::string rig_calibration_label;
};

struct Artifact {
  std::string step;  // producing step
  // "response", "hdr", "tonemapped", "disparity", "ground_truth",
  // "metrics", "export", "report", ...
  std::string kind;
  std::string path;  // relative to the session folder
  std::string params_json;
  std::string sha256;
  int64_t size_bytes = 0;
};

// The metrics row of the structured-light ground truth itself, scored
// against the simulator's exact truth (sessions that have both).
inline constexpr char kGroundTruthMethod[] = "structured_light";

// One metrics row (thesis Table 5.2 for this session).
struct Metric {
  // experiment::MethodName ("ldr", ..., "fused") or kGroundTruthMethod.
  std::string method;
  std::string ground_truth;  // "structured_light" or "simulation"
  double rmse = 0;
  double mae = 0;
  double bad_0_5 = 0;  // percent of scored pixels
  double bad_1 = 0;
  double bad_2 = 0;
  double bad_4 = 0;
  double coverage = 0;  // percent of ground-truth pixels with a disparity
};

// What the caller remembers between runs. Calls are serialised by the
// pipeline (one at a time), possibly from worker threads.
class RunStore {
 public:
  virtual ~RunStore() = default;
  // The artifacts recorded for `step` by an earlier run whose inputs and
  // parameters hashed to `input_hash`; empty when there was none. The
  // pipeline reuses them only if every file still exists with its sha256.
  virtual std::vector<Artifact> Lookup(const std::string& step,
                                       const std::string& input_hash) = 0;
  // `step` finished (all its files are on disk): record its artifacts,
  // replacing what was recorded for the step before.
  virtual absl::Status Record(const std::string& step,
                              const std::string& input_hash,
                              const std::vector<Artifact>& artifacts) = 0;
  // The evaluate step's rows, replacing the session's earlier rows.
  virtual absl::Status RecordMetrics(const std::vector<Metric>& metrics) = 0;
};

// Calls are serialised by the pipeline (one at a time), possibly from worker
// threads.
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  // Between steps and inside long ones: non-OK (CANCELLED, ABORTED) stops
  // the run, which returns that status.
  virtual absl::Status Checkpoint() = 0;
  // `done` of `total` units of work, `what` for people ("stereo: reinhard").
  virtual void Progress(int64_t done, int64_t total,
                        const std::string& what) = 0;
  virtual void Info(const std::string& message) = 0;
  virtual void Warn(const std::string& message) = 0;
  // `step` was computed (not reused) and recorded, `took` after it started
  // (wall time, its inputs' hashing included).
  virtual void StepComputed(const std::string& step, absl::Duration took) = 0;
};

// The option structs the steps run with. A step's cache key holds the
// canonical JSON of exactly the structs it uses, as it uses them, so that
// changing a field (or a default in a header) recomputes that step and what
// depends on it, and nothing else.
struct StepOptions {
  // The thesis experiment's stages (processing/experiment): response,
  // hdr, tonemap, stereo, fusion, evaluate and the report's error maps
  // each hash and use the part they run. The stereo and fusion steps set
  // the disparity range from the ground truth.
  experiment::ExperimentOptions experiment;
  structured_light::DecodeOptions sl_decode;             // sl_groundtruth
  structured_light::GroundTruthOptions sl_ground_truth;  // sl_groundtruth

  // INVALID_ARGUMENT naming the first field that breaks a rule
  // ("experiment.ldr_stereo.radius is 0; ...").
  absl::Status Validate() const;
};

struct RunOptions {
  std::vector<std::string> steps;  // empty = all; dependencies are added
  bool force = false;              // recompute even when unchanged
  int threads = 2;                 // independent steps run in parallel
  StepOptions step_options;
};

struct RunSummary {
  std::vector<std::string> computed;  // steps recomputed, in order
  std::vector<std::string> reused;    // steps whose artifacts were reused
  std::vector<Metric> metrics;        // when evaluate ran or was reused
  std::string report_path;            // relative; when report ran
};

// The manifest a computed step writes as pipeline/<step>.json (what it
// read and wrote, so that a step without outputs is remembered too):
// {"input_hash", "outputs": [{"path", "sha256"}, ...], "params", "step",
// "version"}, indented by 2, with a final newline. Built with nlohmann-json:
// every string is escaped, bytes that are not UTF-8 become U+FFFD, and a NaN
// or infinite number in `params` becomes null.
std::string StepManifestJson(const std::string& step,
                             const std::string& input_hash,
                             const nlohmann::json& params,
                             const std::vector<Artifact>& outputs);

// FAILED_PRECONDITION naming what is missing (no stereo frames, a
// structured-light capture without some bit plane, ...), INVALID_ARGUMENT
// for unknown steps or bad step options; the status of the failing step
// otherwise.
absl::StatusOr<RunSummary> Run(const SessionInput& input,
                               const RunOptions& options, RunStore& store,
                               RunObserver& observer);

}  // namespace hdrstereo::pipeline

#endif  // HDRSTEREO_PROCESSING_PIPELINE_PIPELINE_H_
