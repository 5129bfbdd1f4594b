// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/processing_job.h"

#include <fnmatch.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "daemon/jobs/capture_plan.h"
#include "daemon/jobs/slurm_processing.h"
#include "daemon/store/artifact_repository.h"
#include "daemon/store/calibration_repository.h"
#include "daemon/store/frame_repository.h"
#include "daemon/store/job_repository.h"
#include "daemon/store/names.h"
#include "daemon/store/session_repository.h"
#include "processing/base/status_macros.h"
#include "processing/io/capture_layout.h"
#include "processing/io/middlebury.h"
#include "processing/pipeline/memory_estimate.h"
#include "processing/pipeline/pipeline.h"
#include "processing/pipeline/session_files.h"

namespace hdrstereo::jobs {
namespace {

namespace fs = std::filesystem;

// A capture with the frames its plan expects and those recorded.
struct CaptureState {
  store::CaptureRecord capture;
  // With the exposures automatic bracketing chose, where it did.
  v1::CapturePlan plan;
  std::optional<hdr::AutoBracketResult> auto_bracket;
  std::vector<store::FrameRecord> frames;
  std::vector<std::string> missing;  // relative stems, in capture order
};

// The frames a plan expects depend only on the projector's size (the
// number of Gray-code bits), which is the rig's.
RigLimits FrameLimits(const hardware::Rig& rig) {
  RigLimits limits;
  if (rig.projector() != nullptr) {
    limits.projector_size = rig.projector()->resolution();
  }
  return limits;
}

absl::StatusOr<std::vector<CaptureState>> ReadCaptures(
    store::Store& store, const hardware::Rig& rig, absl::string_view session) {
  store::FrameRepository repository(store);
  ASSIGN_OR_RETURN(std::vector<store::CaptureRecord> captures,
                   repository.CapturesOfSession(session));
  std::vector<CaptureState> out;
  for (const store::CaptureRecord& capture : captures) {
    CaptureState state;
    state.capture = capture;
    if (!state.plan.ParseFromString(capture.plan)) {
      return absl::DataLossError(
          absl::StrCat("the plan of capture ", capture.id, " cannot be read"));
    }
    ASSIGN_OR_RETURN(std::optional<hdr::AutoBracketResult> chosen,
                     RecordedAutoBracket(absl::StrCat("capture ", capture.id),
                                         capture.auto_bracket));
    if (chosen.has_value()) {
      state.plan = WithChosenExposures(state.plan, *chosen);
      state.auto_bracket = std::move(*chosen);
    }
    ASSIGN_OR_RETURN(std::vector<store::FrameRecord> frames,
                     repository.FramesOfCapture(capture.id));
    state.frames = std::move(frames);
    if (ChoosesExposuresAtTheRig(state.plan)) {
      state.missing.push_back(absl::StrCat(
          io::CaptureDir(capture.id), " (its exposures are not chosen yet)"));
    }
    std::set<int> recorded;
    for (const store::FrameRecord& f : state.frames) {
      recorded.insert(f.sequence);
    }
    for (const FrameSpec& spec :
         ExpandPlan(state.plan, FrameLimits(rig), capture.id)) {
      if (!recorded.contains(spec.sequence)) {
        state.missing.push_back(spec.relative_stem);
      }
    }
    out.push_back(std::move(state));
  }
  return out;
}

// The latest complete capture of `kind`; FAILED_PRECONDITION naming what is
// missing when there is none.
absl::StatusOr<const CaptureState*> LatestComplete(
    const std::vector<CaptureState>& captures, io::CaptureKind kind,
    absl::string_view session, absl::string_view what) {
  const CaptureState* incomplete = nullptr;
  for (auto it = captures.rbegin(); it != captures.rend(); ++it) {
    if (it->capture.kind != kind) continue;
    if (it->missing.empty()) return &*it;
    if (incomplete == nullptr) incomplete = &*it;
  }
  if (incomplete == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("session \"", session, "\" has no ", what,
                     " capture to process; capture one first"));
  }
  return absl::FailedPreconditionError(absl::StrFormat(
      "%s capture %d of session \"%s\" is incomplete: %d of %d frames are "
      "missing (first: %s); resubmit the capture to take them",
      what, incomplete->capture.id, session, incomplete->missing.size(),
      incomplete->missing.size() + incomplete->frames.size(),
      incomplete->missing.front()));
}

struct Inputs {
  const CaptureState* stereo = nullptr;
  const CaptureState* structured_light = nullptr;  // may stay null
};

// What the pipeline will read, checked against the steps it will run.
absl::StatusOr<Inputs> ChooseInputs(const std::vector<CaptureState>& captures,
                                    absl::string_view session,
                                    const std::vector<std::string>& steps) {
  Inputs inputs;
  ASSIGN_OR_RETURN(const CaptureState* stereo,
                   LatestComplete(captures, io::CaptureKind::kBracketedStereo,
                                  session, "bracketed-stereo"));
  inputs.stereo = stereo;
  const bool wants_sl =
      std::find(steps.begin(), steps.end(), "sl_groundtruth") != steps.end();
  const bool has_sl =
      std::any_of(captures.begin(), captures.end(), [](const auto& c) {
        return c.capture.kind == io::CaptureKind::kStructuredLight;
      });
  if (wants_sl && has_sl) {
    ASSIGN_OR_RETURN(const CaptureState* sl,
                     LatestComplete(captures, io::CaptureKind::kStructuredLight,
                                    session, "structured-light"));
    inputs.structured_light = sl;
  }
  return inputs;
}

// Capture jobs of the session that are still to run or running, submitted
// before `before_id` (0 = any).
absl::StatusOr<std::vector<int64_t>> PendingCaptures(store::Store& store,
                                                     absl::string_view session,
                                                     int64_t before_id) {
  store::JobRepository jobs(store);
  ASSIGN_OR_RETURN(
      std::vector<store::JobRecord> pending,
      jobs.List({.session = std::string(session),
                 .states = {store::JobState::kQueued, store::JobState::kRunning,
                            store::JobState::kPaused},
                 .after_id = 0,
                 .limit = 1000}));
  std::vector<int64_t> out;
  for (const store::JobRecord& job : pending) {
    if (job.kind == store::JobKind::kCapture &&
        (before_id == 0 || job.id < before_id)) {
      out.push_back(job.id);
    }
  }
  return out;
}

// The frame's role from its path in the capture layout; nullopt for a path
// outside it.
std::optional<io::FrameRole> RoleOf(const std::string& path) {
  absl::StatusOr<io::FramePath> parsed = io::ParseFramePath(path);
  if (!parsed.ok()) return std::nullopt;
  return parsed->key.role;
}

// The run's sizes from what the frames' rows recorded (no file is read):
// frames decode to 3 channels of 8 bits, or of 16 from RAW and TIFF.
// nullopt when the stereo frames' size is unknown (RAW frames are not
// decoded at capture, and their rows say 0 x 0); structured-light frames
// of unknown size are taken to be as large as the stereo frames.
std::optional<pipeline::RunShape> ShapeOf(const Inputs& inputs) {
  const auto sample_bytes = [](hardware::ImageFormat format) {
    return format == hardware::ImageFormat::kJpeg ||
                   format == hardware::ImageFormat::kPng8
               ? 1
               : 2;
  };
  pipeline::RunShape shape;
  for (const store::FrameRecord& f : inputs.stereo->frames) {
    if (f.view_index != 0 || RoleOf(f.path) != io::FrameRole::kStereo) {
      continue;
    }
    shape.image = cv::Size(f.width_px, f.height_px);
    shape.bytes_per_pixel = 3 * sample_bytes(f.format);
    ++shape.exposures;
  }
  if (shape.image.width <= 0 || shape.image.height <= 0) return std::nullopt;
  if (inputs.structured_light != nullptr) {
    for (const store::FrameRecord& f : inputs.structured_light->frames) {
      if (f.view_index != 0) continue;
      shape.sl_image = f.width_px > 0 && f.height_px > 0
                           ? cv::Size(f.width_px, f.height_px)
                           : shape.image;
      shape.sl_bytes_per_sample = sample_bytes(f.format);
      ++shape.sl_frames;
    }
  }
  return shape;
}

// RESOURCE_EXHAUSTED when the run needs more than the budget. Frames of
// unknown size (RAW) are not checked.
absl::Status CheckMemory(const Inputs& inputs,
                         const std::vector<std::string>& steps,
                         const ProcessingEnvironment& environment,
                         absl::string_view session) {
  if (environment.memory.bytes <= 0) return absl::OkStatus();
  const std::optional<pipeline::RunShape> shape = ShapeOf(inputs);
  if (!shape) return absl::OkStatus();
  pipeline::RunOptions options;
  options.steps = steps;
  options.threads = environment.slurm ? environment.slurm->cpus_per_task
                                      : environment.threads;
  ASSIGN_OR_RETURN(const pipeline::MemoryEstimate estimate,
                   pipeline::EstimateMemory(*shape, options));
  if (estimate.peak_bytes <= environment.memory.bytes) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrCat(
      "processing session ", session, " would need ", estimate.Describe(*shape),
      ", more than the ", pipeline::FormatBytes(environment.memory.bytes),
      " a processing job may use (", environment.memory.source,
      "); process fewer steps, or give processing more memory"));
}

// DATA_LOSS for a recorded path outside the capture layout (capture jobs
// only record io::FrameStem paths).
absl::StatusOr<pipeline::FrameInput> ToFrameInput(const store::FrameRecord& f) {
  absl::StatusOr<io::FramePath> parsed = io::ParseFramePath(f.path);
  if (!parsed.ok()) {
    return absl::DataLossError(
        absl::StrCat("frame ", f.id, ": ", parsed.status().message()));
  }
  return pipeline::FrameInput{.path = f.path,
                              .capture_kind = f.capture_kind,
                              .capture_id = f.capture_id,
                              .role = parsed->key.role,
                              .view_index = f.view_index,
                              .exposure_s = f.exposure_s,
                              .pattern = f.pattern,
                              .inverse = f.inverse,
                              .sha256 = f.sha256};
}

class StoreAdapter : public pipeline::RunStore {
 public:
  StoreAdapter(store::Store& store, int64_t session_id, int64_t job_id)
      : artifacts_(store), session_id_(session_id), job_id_(job_id) {}

  std::vector<pipeline::Artifact> Lookup(
      const std::string& step, const std::string& input_hash) override {
    absl::StatusOr<std::vector<store::ArtifactRecord>> rows =
        artifacts_.ForStep(session_id_, step, input_hash);
    std::vector<pipeline::Artifact> out;
    if (!rows.ok()) return out;  // recomputing is always safe
    for (const store::ArtifactRecord& r : *rows) {
      out.push_back({.step = r.step,
                     .kind = r.kind,
                     .path = r.path,
                     .params_json = r.params_json,
                     .sha256 = r.sha256,
                     .size_bytes = r.size_bytes});
    }
    return out;
  }

  absl::Status Record(
      const std::string& step, const std::string& input_hash,
      const std::vector<pipeline::Artifact>& artifacts) override {
    std::vector<store::ArtifactRecord> rows;
    for (const pipeline::Artifact& a : artifacts) {
      rows.push_back({.id = 0,
                      .job_id = job_id_,
                      .step = step,
                      .kind = a.kind,
                      .path = a.path,
                      .params_json = a.params_json,
                      .params_hash = input_hash,
                      .sha256 = a.sha256,
                      .size_bytes = a.size_bytes,
                      .create_time_ms = 0});
    }
    return artifacts_.ReplaceStep(session_id_, job_id_, step, rows);
  }

  absl::Status RecordMetrics(
      const std::vector<pipeline::Metric>& metrics) override {
    std::vector<store::MetricRecord> rows;
    for (const pipeline::Metric& m : metrics) {
      rows.push_back({.method = m.method,
                      .ground_truth = m.ground_truth,
                      .rmse = m.rmse,
                      .mae = m.mae,
                      .bad_0_5 = m.bad_0_5,
                      .bad_1 = m.bad_1,
                      .bad_2 = m.bad_2,
                      .bad_4 = m.bad_4,
                      .coverage = m.coverage,
                      .job_id = job_id_});
    }
    return artifacts_.ReplaceMetrics(session_id_, job_id_, rows);
  }

 private:
  store::ArtifactRepository artifacts_;
  const int64_t session_id_;
  const int64_t job_id_;
};

// The event of a computed step, which the step-time metric counts.
void StepComputedEvent(JobContext& context, const std::string& step,
                       double seconds) {
  context.Info(absl::StrFormat("%s: computed in %.2f s", step, seconds),
               store::EventTag(store::EventKind::kStepComputed, step, seconds));
}

class JobObserver : public pipeline::RunObserver {
 public:
  explicit JobObserver(JobContext& context) : context_(context) {}
  absl::Status Checkpoint() override { return context_.Checkpoint(); }
  void Progress(int64_t done, int64_t total, const std::string& what) override {
    // Progress is for people; a failure to record it must not fail the job.
    context_.Progress(done, total, what).IgnoreError();
  }
  void Info(const std::string& message) override { context_.Info(message); }
  void Warn(const std::string& message) override { context_.Warn(message); }
  void StepComputed(const std::string& step, absl::Duration took) override {
    StepComputedEvent(context_, step, absl::ToDoubleSeconds(took));
  }

 private:
  JobContext& context_;
};

std::string ExposureList(const CaptureState& capture) {
  std::set<double> exposures;
  for (const store::FrameRecord& f : capture.frames) {
    if (RoleOf(f.path) == io::FrameRole::kStereo) {
      exposures.insert(f.exposure_s);
    }
  }
  std::vector<std::string> tags;
  for (auto it = exposures.rbegin(); it != exposures.rend(); ++it) {
    tags.push_back(io::ExposureTag(*it));
  }
  return absl::StrJoin(tags, ", ");
}

bool SameFiles(const std::vector<pipeline::Artifact>& a,
               const std::vector<pipeline::Artifact>& b) {
  return std::equal(
      a.begin(), a.end(), b.begin(), b.end(),
      [](const pipeline::Artifact& x, const pipeline::Artifact& y) {
        return x.path == y.path && x.sha256 == y.sha256;
      });
}

// Records what a run elsewhere produced, as a run here would have: the
// steps whose records the store does not hold yet, and the evaluate step's
// metrics with it. The artifacts were verified by RunOnSlurm.
absl::Status RecordResult(const pipeline::JobResult& result,
                          const std::filesystem::path& session_dir,
                          pipeline::RunStore& store) {
  for (const pipeline::StepRecord& step : result.steps) {
    if (SameFiles(store.Lookup(step.step, step.input_hash), step.artifacts)) {
      continue;
    }
    RETURN_IF_ERROR(store.Record(step.step, step.input_hash, step.artifacts));
    for (const pipeline::Artifact& a : step.artifacts) {
      if (a.kind != "metrics") continue;
      ASSIGN_OR_RETURN(std::vector<pipeline::Metric> metrics,
                       pipeline::ReadMetricsFile(session_dir / a.path));
      RETURN_IF_ERROR(store.RecordMetrics(metrics));
    }
  }
  return absl::OkStatus();
}

std::string StepList(const std::vector<std::string>& steps) {
  return steps.empty() ? "nothing" : absl::StrJoin(steps, ", ");
}

}  // namespace

absl::StatusOr<store::JobRecord> SubmitProcessing(
    JobEngine& engine, const hardware::Rig& rig,
    const ProcessingEnvironment& environment,
    const v1::SubmitProcessingRequest& request,
    absl::string_view submitted_by) {
  std::vector<std::string> requested(request.steps().begin(),
                                     request.steps().end());
  ASSIGN_OR_RETURN(std::vector<std::string> steps,
                   pipeline::ResolveSteps(requested));
  store::Store& store = engine.store();
  ASSIGN_OR_RETURN(std::vector<CaptureState> captures,
                   ReadCaptures(store, rig, request.session()));
  ASSIGN_OR_RETURN(std::vector<int64_t> pending,
                   PendingCaptures(store, request.session(), 0));
  // With captures still to come, the job checks its inputs when it starts.
  if (pending.empty()) {
    ASSIGN_OR_RETURN(const Inputs inputs,
                     ChooseInputs(captures, request.session(), steps));
    RETURN_IF_ERROR(CheckMemory(inputs, steps, environment, request.session()));
  }
  return engine.Submit(
      store::JobKind::kProcessing, request.session(),
      request.SerializeAsString(), static_cast<int64_t>(steps.size()),
      absl::StrCat("queued processing: ", absl::StrJoin(steps, ", "),
                   request.force() ? " (forced)" : "",
                   pending.empty()
                       ? ""
                       : absl::StrCat(" after capture job(s) ",
                                      absl::StrJoin(pending, ", "))),
      submitted_by);
}

absl::StatusOr<std::vector<std::string>> SelectSessions(
    store::Store& store, const std::vector<std::string>& selectors, bool all) {
  if (all == !selectors.empty()) {
    return absl::InvalidArgumentError(
        "name sessions (names or globs such as nightly-2026-*) or all "
        "sessions, not both and not neither");
  }
  for (const std::string& selector : selectors) {
    if (selector.empty() || selector.size() > store::kMaxNameLength) {
      return absl::InvalidArgumentError(
          absl::StrCat("a session selector must have 1 to ",
                       store::kMaxNameLength, " bytes; got ", selector.size()));
    }
  }
  std::vector<std::string> names;
  store::SessionRepository sessions(store);
  std::string after;
  do {
    ASSIGN_OR_RETURN(store::SessionPage page, sessions.List(after, 500));
    for (const store::SessionRecord& s : page.sessions) {
      names.push_back(s.name);
    }
    after = page.next_after;
  } while (!after.empty());
  if (all) return names;
  std::set<std::string> chosen;
  for (const std::string& selector : selectors) {
    bool matched = false;
    for (const std::string& name : names) {
      if (::fnmatch(selector.c_str(), name.c_str(), 0) == 0) {
        chosen.insert(name);
        matched = true;
      }
    }
    if (!matched) {
      return absl::NotFoundError(
          absl::StrCat("no session matches \"", selector, "\""));
    }
  }
  return std::vector<std::string>(chosen.begin(), chosen.end());
}

absl::StatusOr<BatchSubmission> SubmitProcessingBatch(
    JobEngine& engine, const hardware::Rig& rig,
    const ProcessingEnvironment& environment,
    const v1::SubmitProcessingBatchRequest& request,
    absl::string_view submitted_by) {
  std::vector<std::string> steps(request.steps().begin(),
                                 request.steps().end());
  RETURN_IF_ERROR(pipeline::ResolveSteps(steps).status());
  ASSIGN_OR_RETURN(
      const std::vector<std::string> names,
      SelectSessions(engine.store(),
                     {request.sessions().begin(), request.sessions().end()},
                     request.all_sessions()));
  BatchSubmission out;
  for (const std::string& name : names) {
    v1::SubmitProcessingRequest one;
    one.set_session(name);
    *one.mutable_steps() = request.steps();
    one.set_force(request.force());
    absl::StatusOr<store::JobRecord> job =
        SubmitProcessing(engine, rig, environment, one, submitted_by);
    if (job.ok()) {
      out.jobs.push_back(*std::move(job));
    } else {
      out.skipped.emplace_back(name, std::string(job.status().message()));
    }
  }
  return out;
}

absl::Status RunProcessingJob(const hardware::Rig& rig,
                              const ProcessingEnvironment& environment,
                              JobContext& context) {
  const store::JobRecord& job = context.job();
  v1::SubmitProcessingRequest request;
  if (!request.ParseFromString(job.request)) {
    return absl::DataLossError("the job's processing request cannot be read");
  }
  store::Store& store = context.store();

  // Captures submitted before this job are its input: wait for them.
  for (int64_t waited = 0;; ++waited) {
    ASSIGN_OR_RETURN(std::vector<int64_t> pending,
                     PendingCaptures(store, job.session, job.id));
    if (pending.empty()) break;
    if (waited == 0) {
      RETURN_IF_ERROR(
          context.Progress(0, job.progress_total,
                           absl::StrCat("waiting for capture job(s) ",
                                        absl::StrJoin(pending, ", "))));
    }
    RETURN_IF_ERROR(context.Checkpoint());
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }

  pipeline::RunOptions options;
  options.steps = {request.steps().begin(), request.steps().end()};
  options.force = request.force();
  options.threads = environment.threads;
  ASSIGN_OR_RETURN(std::vector<std::string> steps,
                   pipeline::ResolveSteps(options.steps));
  ASSIGN_OR_RETURN(std::vector<CaptureState> captures,
                   ReadCaptures(store, rig, job.session));
  ASSIGN_OR_RETURN(Inputs inputs, ChooseInputs(captures, job.session, steps));
  // A batch job already on the cluster is followed, whatever the budget
  // says now.
  if (!job.cluster_job_id.has_value()) {
    RETURN_IF_ERROR(CheckMemory(inputs, steps, environment, job.session));
  }

  pipeline::SessionInput input;
  input.session_dir = store.files().SessionDir(job.session);
  input.session_name = job.session;
  for (const CaptureState* capture : {inputs.stereo, inputs.structured_light}) {
    if (capture == nullptr) continue;
    for (const store::FrameRecord& f : capture->frames) {
      ASSIGN_OR_RETURN(pipeline::FrameInput frame, ToFrameInput(f));
      input.frames.push_back(std::move(frame));
    }
  }
  const v1::BracketedStereoPlan& stereo_plan =
      inputs.stereo->plan.bracketed_stereo();
  input.baseline_mm = stereo_plan.baseline_mm();
  if (const hardware::Projector* projector = rig.projector();
      projector != nullptr) {
    input.projector_size = std::make_pair(projector->resolution().width,
                                          projector->resolution().height);
  }
  const std::string truth_dir = io::TruthDir(inputs.stereo->capture.id) + "/";
  std::error_code ec;
  if (fs::exists(input.session_dir / truth_dir / "disp0.pfm", ec)) {
    input.sim_truth_disparity = truth_dir + "disp0.pfm";
    input.sim_truth_nonoccluded = truth_dir + "nonocc0.png";
    // The simulated camera's intrinsics, for the export's calib.txt
    // (without them the export uses a nominal camera and warns).
    pipeline::ApplyCalib(input.session_dir / truth_dir / io::kCalibFile, &input)
        .IgnoreError();
  }
  input.capture_summary = environment.summary;
  // Without a calibration capture of its own, the session is rectified with
  // the rig's latest calibration (the report says which).
  ASSIGN_OR_RETURN(
      const std::optional<store::CalibrationRecord> rig_calibration,
      store::CalibrationRepository(store).Latest());
  if (rig_calibration.has_value()) {
    input.rig_calibration =
        store.files().root() / rig_calibration->dir / "calibration.yml";
    input.rig_calibration_label = absl::StrFormat(
        "rig calibration %d (capture %d of session %s, %d poses)",
        rig_calibration->id, rig_calibration->capture_id,
        rig_calibration->session, rig_calibration->poses);
    input.capture_summary.emplace_back(
        "rectification",
        absl::StrFormat("%s, stereo rms %.3f px", input.rig_calibration_label,
                        rig_calibration->rms_stereo));
  }
  input.capture_summary.emplace_back(
      "stereo capture",
      absl::StrFormat("capture %d (job %d): %d frames, %d views, baseline "
                      "%.1f mm",
                      inputs.stereo->capture.id, inputs.stereo->capture.job_id,
                      inputs.stereo->frames.size(),
                      stereo_plan.views() > 0 ? stereo_plan.views() : 2,
                      stereo_plan.baseline_mm()));
  input.capture_summary.emplace_back("exposures", ExposureList(*inputs.stereo));
  if (inputs.stereo->auto_bracket.has_value()) {
    for (auto& row : inputs.stereo->auto_bracket->SummaryRows()) {
      input.capture_summary.push_back(std::move(row));
    }
    input.capture_summary.emplace_back(
        "fixed bracket (thesis)",
        absl::StrFormat("%d exposures, 1/%.0f .. 1/%.0f s",
                        v1::kDefaultStereoExposuresS.size(),
                        1 / v1::kDefaultStereoExposuresS.back(),
                        1 / v1::kDefaultStereoExposuresS.front()));
  }
  if (inputs.structured_light != nullptr) {
    input.capture_summary.emplace_back(
        "structured-light capture",
        absl::StrFormat("capture %d (job %d): %d frames",
                        inputs.structured_light->capture.id,
                        inputs.structured_light->capture.job_id,
                        inputs.structured_light->frames.size()));
  } else {
    input.capture_summary.emplace_back("structured-light capture", "none");
  }
  for (const CaptureState* capture : {inputs.stereo, inputs.structured_light}) {
    if (capture == nullptr || capture->capture.job_id == 0) continue;
    absl::StatusOr<store::JobRecord> capture_job =
        store::JobRepository(store).Get(capture->capture.job_id);
    if (capture_job.ok() && capture_job->start_time_ms &&
        capture_job->end_time_ms) {
      input.capture_summary.emplace_back(
          absl::StrCat("capture job ", capture_job->id, " time"),
          absl::StrFormat("%.1f s", (*capture_job->end_time_ms -
                                     *capture_job->start_time_ms) /
                                        1000.0));
    }
  }

  StoreAdapter adapter(store, job.session_id, job.id);
  const auto total = static_cast<int64_t>(steps.size());
  if (job.cluster_job_id.has_value() && !environment.slurm.has_value()) {
    // Running it here too would write the same files as the batch job.
    return absl::FailedPreconditionError(absl::StrCat(
        "job ", job.id, " was submitted to Slurm as job ", *job.cluster_job_id,
        " and this daemon runs processing locally: restart it with "
        "--processing-backend slurm to follow the batch job, or scancel it "
        "and submit the processing again"));
  }
  if (environment.slurm.has_value()) {
    ASSIGN_OR_RETURN(
        const pipeline::JobResult result,
        slurm::RunOnSlurm(
            *environment.slurm,
            {.input = input, .steps = options.steps, .force = options.force},
            context));
    RETURN_IF_ERROR(RecordResult(result, input.session_dir, adapter));
    std::vector<std::string> computed, reused;
    for (const pipeline::StepRecord& step : result.steps) {
      (step.computed ? computed : reused).push_back(step.step);
      if (step.computed && step.seconds.has_value()) {
        StepComputedEvent(context, step.step, *step.seconds);
      }
      for (const pipeline::Artifact& a : step.artifacts) {
        if (a.kind == "report" && absl::EndsWith(a.path, ".html")) {
          context.Info(
              absl::StrCat("report: ", (input.session_dir / a.path).string()));
        }
      }
    }
    context.Info(absl::StrCat("computed: ", StepList(computed),
                              "; reused: ", StepList(reused)));
    return context.Progress(total, total, "done");
  }
  JobObserver observer(context);
  ASSIGN_OR_RETURN(pipeline::RunSummary summary,
                   pipeline::Run(input, options, adapter, observer));
  context.Info(absl::StrCat("computed: ", StepList(summary.computed),
                            "; reused: ", StepList(summary.reused)));
  if (!summary.report_path.empty()) {
    context.Info(absl::StrCat(
        "report: ", (input.session_dir / summary.report_path).string()));
  }
  return context.Progress(total, total, "done");
}

}  // namespace hdrstereo::jobs
