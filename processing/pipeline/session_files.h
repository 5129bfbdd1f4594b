// SPDX-License-Identifier: GPL-3.0-or-later
//
// The pipeline without a daemon (hdrstereo-proc pipeline): a session's
// frames found from the capture layout on disk, a RunStore kept in a JSON
// file in the session folder, and the two files of a run that hdrstereod
// hands to another process (a Slurm batch job): the request it writes
// before submitting and the result the run writes when it ends.
#ifndef HDRSTEREO_PROCESSING_PIPELINE_SESSION_FILES_H_
#define HDRSTEREO_PROCESSING_PIPELINE_SESSION_FILES_H_

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "processing/pipeline/pipeline.h"

namespace hdrstereo::pipeline {

// Finds the frames of the capture layout (processing/io/capture_layout.h):
// every file that io::ParseFramePath accepts, with capture_kind from its
// role (stereo, ambient -> "bracketed_stereo", structured_light,
// calibration); views 0 and 1 only. Frames are ordered by capture id, view,
// role and file name; sha256 is left empty. When the latest stereo
// capture's io::TruthDir holds disp0.pfm (the simulator's exact truth) it
// becomes sim_truth_disparity (with nonocc0.png), and its calib.txt gives
// baseline_mm and the intrinsics. session_name is the folder's name.
// NOT_FOUND when `session_dir` is not a folder; a session without captures
// gives no frames (not an error).
absl::StatusOr<SessionInput> DiscoverSession(
    const std::filesystem::path& session_dir);

// The files of this header that a run elsewhere writes or reads (request,
// result, pipeline state, metrics) are read as untrusted: at most 64 MiB
// (a larger file is refused by its size before it is read), bounded counts
// (100000 frames, artifacts of a step and metrics rows, 256 steps) and string
// lengths, every field of its JSON type, and every path relative to the session
// folder (io::ValidateRelativePath); DATA_LOSS "not a <document>: <field>:
// <why>" otherwise, the field named (e.g. "steps[2].artifacts[0].path"), what
// it held quoted through QuoteInput.

// A RunStore in one JSON file, rewritten atomically on every change:
//   {"steps": {"<step>": {"input_hash": "...", "artifacts": [...]}},
//    "metrics": [...]}
class JsonRunStore : public RunStore {
 public:
  // Reads `path` if it exists (a missing file is an empty store); the
  // errors of Parse, with the path in front.
  static absl::StatusOr<JsonRunStore> Open(std::filesystem::path path);
  // The store that `path` holds when it holds `json_text` (nothing is read
  // or written). DATA_LOSS "not a pipeline state file: ...".
  static absl::StatusOr<JsonRunStore> Parse(absl::string_view json_text,
                                            std::filesystem::path path);

  std::vector<Artifact> Lookup(const std::string& step,
                               const std::string& input_hash) override;
  absl::Status Record(const std::string& step, const std::string& input_hash,
                      const std::vector<Artifact>& artifacts) override;
  absl::Status RecordMetrics(const std::vector<Metric>& metrics) override;

  const std::vector<Metric>& metrics() const { return metrics_; }
  // What was recorded for `step` (its input hash and artifacts), if any.
  std::optional<std::pair<std::string, std::vector<Artifact>>> Entry(
      const std::string& step) const;
  // The steps with a record, in name order.
  std::vector<std::string> StepNames() const;

 private:
  explicit JsonRunStore(std::filesystem::path path) : path_(std::move(path)) {}
  absl::Status Save() const;

  std::filesystem::path path_;
  std::map<std::string, std::pair<std::string, std::vector<Artifact>>> steps_;
  std::vector<Metric> metrics_;
};

// metrics.json as the evaluate step writes it: {"metrics": [{"method": ...,
// "ground_truth": ..., "rmse": ..., "mae": ..., "bad_0_5": ..., "bad_1": ...,
// "bad_2": ..., "bad_4": ..., "coverage": ...}, ...]} (stable formatting).
// Fills in->intrinsics (and in->baseline_mm when unset) from a Middlebury
// calib.txt (io::ReadCalib); fields already set are left alone. The
// errors of io::ReadCalib, `in` unchanged.
absl::Status ApplyCalib(const std::filesystem::path& path, SessionInput* in);

// A NaN or infinite number is written as null (JSON has neither) and read
// back as NaN: a metric that could not be computed.
std::string MetricsToJson(const std::vector<Metric>& metrics);
// DATA_LOSS "metrics.json: not a metrics file: ...".
absl::StatusOr<std::vector<Metric>> MetricsFromJson(absl::string_view text);
// The metrics file at `path` (a run's metrics/metrics.json, or one a cluster
// node names), read as untrusted like the files below: refused by its size
// before it is read (DATA_LOSS "<path>: metrics file of N bytes, more than
// the limit of ...; not read"), NOT_FOUND "<path>: no metrics file", else
// MetricsFromJson's errors with `path` in front instead of "metrics.json".
absl::StatusOr<std::vector<Metric>> ReadMetricsFile(
    const std::filesystem::path& path);

// Sorted by ground truth, then RMSE (the order tables show them in), a NaN
// RMSE last.
std::vector<Metric> SortMetrics(std::vector<Metric> metrics);
// Per row of `metrics`: whether its RMSE is above that of "ldr" against the
// same ground truth, i.e. the method did worse than the single middle
// exposure every method is meant to beat. False for LDR itself, for the
// ground-truth row (kGroundTruthMethod), without an LDR row, and for a NaN
// RMSE on either side.
std::vector<bool> WorseThanLdr(const std::vector<Metric>& metrics);
// The metrics as a Markdown table in SortMetrics order.
std::string FormatMetrics(const std::vector<Metric>& metrics);

// A run for the daemon, in its job folder (<session>/jobs/<job id>/):
// request.json holds the inputs the daemon chose from its database (every
// frame with the sha256 recorded at capture) and the run's steps and force
// flag; paths in it are relative to the session folder, so that the folder
// may be mounted elsewhere on the node that runs it.
inline constexpr char kJobRequestFile[] = "request.json";
inline constexpr char kJobResultFile[] = "result.json";

struct JobRequest {
  SessionInput input;  // session_dir is not stored
  std::vector<std::string> steps;
  bool force = false;
};

// Both atomically. The reader sets input.session_dir to `session_dir`;
// DATA_LOSS for a file that is not a request (the errors of
// ParseJobRequest, with the path in front), NOT_FOUND when there is none.
absl::Status WriteJobRequest(const std::filesystem::path& job_dir,
                             const JobRequest& request);
absl::StatusOr<JobRequest> ReadJobRequest(
    const std::filesystem::path& job_dir,
    const std::filesystem::path& session_dir);
// request.json's text. DATA_LOSS "not a pipeline job request: ...".
absl::StatusOr<JobRequest> ParseJobRequest(
    absl::string_view json_text, const std::filesystem::path& session_dir);

// What the run recorded for one step: computed by this run, or reused.
struct StepRecord {
  std::string step;
  std::string input_hash;
  bool computed = false;
  std::vector<Artifact> artifacts;  // paths relative to the session folder
  // A computed step: how long it took (RunObserver::StepComputed); absent
  // from results written before it was kept.
  std::optional<double> seconds;
};

// result.json: the run's status (code and message) and, when it is OK, the
// record of every step it ran.
struct JobResult {
  absl::Status status;
  std::vector<StepRecord> steps;
};
absl::Status WriteJobResult(const std::filesystem::path& job_dir,
                            const JobResult& result);
// NOT_FOUND when the run wrote no result (it never started or was killed);
// DATA_LOSS for a file that is not a result (the errors of ParseJobResult,
// with the path in front).
absl::StatusOr<JobResult> ReadJobResult(const std::filesystem::path& job_dir);
// result.json's text. DATA_LOSS "not a pipeline job result: ...", e.g. for
// an artifact whose path leaves the session folder.
absl::StatusOr<JobResult> ParseJobResult(absl::string_view json_text);

// FAILED_PRECONDITION naming the first frame of `input` that is missing,
// DATA_LOSS for one whose sha256 is not the one recorded (frames without a
// recorded sha256 are only checked to exist).
absl::Status VerifyFrames(const SessionInput& input);
// DATA_LOSS naming the first artifact whose file below `session_dir` is
// missing or does not have its recorded sha256.
absl::Status VerifyArtifacts(const std::filesystem::path& session_dir,
                             const std::vector<Artifact>& artifacts);

}  // namespace hdrstereo::pipeline

#endif  // HDRSTEREO_PROCESSING_PIPELINE_SESSION_FILES_H_
