// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/jobs_service.h"

#include <google/protobuf/util/time_util.h>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "daemon/jobs/capture_job.h"
#include "daemon/jobs/capture_plan.h"
#include "daemon/jobs/processing_job.h"
#include "daemon/rpc/pagination.h"
#include "daemon/rpc/status.h"
#include "daemon/store/frame_repository.h"
#include "daemon/store/names.h"

namespace hdrstereo::rpc {
namespace {

using google::protobuf::util::TimeUtil;
using store::JobState;

v1::JobState ToProto(JobState state) {
  switch (state) {
    case JobState::kQueued:
      return v1::JOB_STATE_QUEUED;
    case JobState::kRunning:
      return v1::JOB_STATE_RUNNING;
    case JobState::kPaused:
      return v1::JOB_STATE_PAUSED;
    case JobState::kSucceeded:
      return v1::JOB_STATE_SUCCEEDED;
    case JobState::kFailed:
      return v1::JOB_STATE_FAILED;
    case JobState::kCancelled:
      return v1::JOB_STATE_CANCELLED;
    case JobState::kInterrupted:
      return v1::JOB_STATE_INTERRUPTED;
    case JobState::kWaiting:
      return v1::JOB_STATE_WAITING;
  }
  return v1::JOB_STATE_UNSPECIFIED;
}

absl::StatusOr<JobState> FromProto(v1::JobState state) {
  switch (state) {
    case v1::JOB_STATE_QUEUED:
      return JobState::kQueued;
    case v1::JOB_STATE_RUNNING:
      return JobState::kRunning;
    case v1::JOB_STATE_PAUSED:
      return JobState::kPaused;
    case v1::JOB_STATE_SUCCEEDED:
      return JobState::kSucceeded;
    case v1::JOB_STATE_FAILED:
      return JobState::kFailed;
    case v1::JOB_STATE_CANCELLED:
      return JobState::kCancelled;
    case v1::JOB_STATE_INTERRUPTED:
      return JobState::kInterrupted;
    case v1::JOB_STATE_WAITING:
      return JobState::kWaiting;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          "states contains ", static_cast<int>(state), ", not a job state"));
  }
}

void ToProto(const store::JobRecord& job, v1::Job* out) {
  out->set_id(job.id);
  out->set_kind(job.kind == store::JobKind::kCapture ? v1::JOB_KIND_CAPTURE
                                                     : v1::JOB_KIND_PROCESSING);
  out->set_session(job.session);
  out->set_state(ToProto(job.state));
  out->mutable_progress()->set_done(job.progress_done);
  out->mutable_progress()->set_total(job.progress_total);
  out->mutable_progress()->set_step(job.step);
  if (job.kind == store::JobKind::kCapture) {
    out->mutable_capture()->ParseFromString(job.request);
  } else {
    out->mutable_processing()->ParseFromString(job.request);
  }
  out->set_error(job.error);
  out->set_submitted_by(job.submitted_by);
  out->set_cluster_job_id(job.cluster_job_id.value_or(0));
  out->set_suspension_reason(job.suspension_reason);
  out->set_instruction(job.instruction);
  *out->mutable_create_time() =
      TimeUtil::MillisecondsToTimestamp(job.create_time_ms);
  if (job.start_time_ms) {
    *out->mutable_start_time() =
        TimeUtil::MillisecondsToTimestamp(*job.start_time_ms);
  }
  if (job.end_time_ms) {
    *out->mutable_end_time() =
        TimeUtil::MillisecondsToTimestamp(*job.end_time_ms);
  }
}

void ToProto(const store::JobEventRecord& event, v1::JobEvent* out) {
  out->set_job_id(event.job_id);
  out->set_sequence(event.sequence);
  *out->mutable_time() = TimeUtil::MillisecondsToTimestamp(event.time_ms);
  out->set_state(ToProto(event.state));
  out->mutable_progress()->set_done(event.progress_done);
  out->mutable_progress()->set_total(event.progress_total);
  out->mutable_progress()->set_step(event.step);
  switch (event.level) {
    case store::EventLevel::kInfo:
      out->set_level(v1::JobEvent::LEVEL_INFO);
      break;
    case store::EventLevel::kWarning:
      out->set_level(v1::JobEvent::LEVEL_WARNING);
      break;
    case store::EventLevel::kError:
      out->set_level(v1::JobEvent::LEVEL_ERROR);
      break;
  }
  out->set_message(event.message);
}

// More than every step named a few times is not a request a person made.
constexpr int kMaxSteps = 64;
// A batch names sessions by globs; a list longer than this is a mistake.
constexpr int kMaxSelectors = 1000;

grpc::Status CheckJobId(int64_t id) {
  if (id <= 0) return InvalidArgument("job_id must be a positive job id");
  return grpc::Status::OK;
}

grpc::Status Reply(const absl::StatusOr<store::JobRecord>& job,
                   v1::Job* response) {
  if (!job.ok()) return ToGrpcStatus(job.status());
  ToProto(*job, response);
  return grpc::Status::OK;
}

}  // namespace

grpc::Status JobsService::SubmitCapture(grpc::ServerContext* context,
                                        const v1::SubmitCaptureRequest* request,
                                        v1::Job* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (absl::Status s = store::ValidateName(request->session(), "session");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  if (!request->has_plan()) return InvalidArgument("plan is required");
  return Reply(
      jobs::SubmitCapture(engine_, rig_, request->session(), request->plan(),
                          caller.principal.name, &disk_),
      response);
}

grpc::Status JobsService::EstimateCapture(
    grpc::ServerContext* context, const v1::EstimateCaptureRequest* request,
    v1::CaptureEstimate* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  // A form estimates before its session is chosen.
  if (!request->session().empty()) {
    if (absl::Status s = store::ValidateName(request->session(), "session");
        !s.ok()) {
      return ToGrpcStatus(s);
    }
  }
  if (!request->has_plan()) return InvalidArgument("plan is required");
  absl::StatusOr<jobs::CaptureEstimate> estimate =
      jobs::EstimateCapture(rig_, request->plan(), disk_);
  if (!estimate.ok()) return ToGrpcStatus(estimate.status());
  response->set_frames(estimate->frames);
  response->set_duration_s(estimate->duration_s);
  response->set_disk_bytes(estimate->disk_bytes);
  response->set_exposures_chosen_at_rig(estimate->exposures_chosen_at_rig);
  return grpc::Status::OK;
}

grpc::Status JobsService::SubmitProcessing(
    grpc::ServerContext* context, const v1::SubmitProcessingRequest* request,
    v1::Job* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (absl::Status s = store::ValidateName(request->session(), "session");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  if (request->steps_size() > kMaxSteps) {
    return InvalidArgument(absl::StrCat("steps has ", request->steps_size(),
                                        " entries; at most ", kMaxSteps,
                                        " are allowed"));
  }
  return Reply(jobs::SubmitProcessing(engine_, rig_, processing_, *request,
                                      caller.principal.name),
               response);
}

grpc::Status JobsService::SubmitProcessingBatch(
    grpc::ServerContext* context,
    const v1::SubmitProcessingBatchRequest* request,
    v1::SubmitProcessingBatchResponse* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (request->steps_size() > kMaxSteps) {
    return InvalidArgument(absl::StrCat("steps has ", request->steps_size(),
                                        " entries; at most ", kMaxSteps,
                                        " are allowed"));
  }
  if (request->sessions_size() > kMaxSelectors) {
    return InvalidArgument(absl::StrCat(
        "sessions has ", request->sessions_size(), " entries; at most ",
        kMaxSelectors, " are allowed (use a glob)"));
  }
  absl::StatusOr<jobs::BatchSubmission> batch = jobs::SubmitProcessingBatch(
      engine_, rig_, processing_, *request, caller.principal.name);
  if (!batch.ok()) return ToGrpcStatus(batch.status());
  for (const store::JobRecord& job : batch->jobs) {
    ToProto(job, response->add_jobs());
  }
  for (const auto& [session, reason] : batch->skipped) {
    v1::SubmitProcessingBatchResponse::Skipped* skipped =
        response->add_skipped();
    skipped->set_session(session);
    skipped->set_reason(reason);
  }
  return grpc::Status::OK;
}

grpc::Status JobsService::Get(grpc::ServerContext* context,
                              const v1::GetJobRequest* request,
                              v1::Job* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (grpc::Status s = CheckJobId(request->job_id()); !s.ok()) return s;
  if (grpc::Status s =
          Reply(engine_.repository().Get(request->job_id()), response);
      !s.ok()) {
    return s;
  }
  store::FrameRepository frames(engine_.store());
  if (response->capture().has_structured_light()) {
    // What the capture measured of its projector, once it has started.
    absl::StatusOr<int64_t> capture = frames.CaptureIdOfJob(response->id());
    if (absl::IsNotFound(capture.status())) return grpc::Status::OK;
    if (!capture.ok()) return ToGrpcStatus(capture.status());
    absl::StatusOr<store::ProjectorTiming> timing =
        frames.ProjectorTimingOf(*capture);
    if (!timing.ok()) return ToGrpcStatus(timing.status());
    v1::ProjectorTiming* out = response->mutable_projector_timing();
    if (timing->latency_s.has_value()) out->set_latency_s(*timing->latency_s);
    if (timing->refresh_hz.has_value()) {
      out->set_refresh_hz(*timing->refresh_hz);
    }
    return grpc::Status::OK;
  }
  if (!jobs::ChoosesExposuresAtTheRig(response->capture())) {
    return grpc::Status::OK;
  }
  // What automatic bracketing chose, once it has.
  absl::StatusOr<std::string> chosen = frames.AutoBracketOfJob(response->id());
  if (absl::IsNotFound(chosen.status())) return grpc::Status::OK;
  if (!chosen.ok()) return ToGrpcStatus(chosen.status());
  absl::StatusOr<std::optional<hdr::AutoBracketResult>> parsed =
      jobs::RecordedAutoBracket(absl::StrCat("job ", response->id()), *chosen);
  if (!parsed.ok()) return ToGrpcStatus(parsed.status());
  if (parsed->has_value()) {
    jobs::ToProto(**parsed, response->mutable_auto_bracket());
  }
  return grpc::Status::OK;  // or not metered yet
}

grpc::Status JobsService::List(grpc::ServerContext* context,
                               const v1::ListJobsRequest* request,
                               v1::ListJobsResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  store::JobFilter filter;
  if (!request->session().empty()) {
    if (absl::Status s = store::ValidateName(request->session(), "session");
        !s.ok()) {
      return ToGrpcStatus(s);
    }
    filter.session = request->session();
  }
  for (int state : request->states()) {
    absl::StatusOr<JobState> parsed =
        FromProto(static_cast<v1::JobState>(state));
    if (!parsed.ok()) return ToGrpcStatus(parsed.status());
    filter.states.push_back(*parsed);
  }
  absl::StatusOr<IdPage> page = ParseIdPage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  filter.after_id = page->after;
  filter.limit = page->size + 1;
  absl::StatusOr<std::vector<store::JobRecord>> jobs =
      engine_.repository().List(filter);
  if (!jobs.ok()) return ToGrpcStatus(jobs.status());
  response->set_next_page_token(FinishIdPage(
      *page, *jobs, [](const store::JobRecord& job) { return job.id; }));
  for (const store::JobRecord& job : *jobs) ToProto(job, response->add_jobs());
  return grpc::Status::OK;
}

grpc::Status JobsService::Watch(grpc::ServerContext* context,
                                const v1::WatchJobRequest* request,
                                grpc::ServerWriter<v1::JobEvent>* writer) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (grpc::Status s = CheckJobId(request->job_id()); !s.ok()) return s;
  if (request->after_sequence() < 0) {
    return InvalidArgument(
        "after_sequence must be 0 (the whole history) or the sequence of "
        "the last event received");
  }
  absl::StatusOr<store::JobRecord> job =
      engine_.repository().Get(request->job_id());
  if (!job.ok()) return ToGrpcStatus(job.status());
  int64_t last = request->after_sequence();
  if (last > 0) {
    // A watcher resuming after its last event: it must be one there is.
    absl::StatusOr<std::vector<store::JobEventRecord>> seen =
        engine_.repository().Events(request->job_id(), last - 1);
    if (!seen.ok()) return ToGrpcStatus(seen.status());
    if (seen->empty()) {
      return grpc::Status(
          grpc::StatusCode::OUT_OF_RANGE,
          absl::StrCat("after_sequence ", last, " is beyond job ",
                       request->job_id(), "'s last event"));
    }
    // Resuming after the final event: nothing is left to send.
    if (seen->size() == 1 && store::IsFinal(seen->front().state)) {
      return grpc::Status::OK;
    }
  }
  while (!context->IsCancelled()) {
    if (engine_.stopping()) {
      return grpc::Status(grpc::StatusCode::UNAVAILABLE,
                          "hdrstereod is shutting down; the job resumes when "
                          "it starts again");
    }
    // Read the generation first: an event recorded after it wakes us.
    const int64_t generation = engine_.event_generation();
    absl::StatusOr<std::vector<store::JobEventRecord>> events =
        engine_.repository().Events(request->job_id(), last);
    if (!events.ok()) return ToGrpcStatus(events.status());
    for (const store::JobEventRecord& event : *events) {
      v1::JobEvent out;
      ToProto(event, &out);
      if (!writer->Write(out)) return grpc::Status::OK;  // watcher left
      last = event.sequence;
      if (store::IsFinal(event.state)) return grpc::Status::OK;
    }
    engine_.WaitForEvents(generation, absl::Now() + absl::Milliseconds(500));
  }
  return grpc::Status::OK;
}

grpc::Status JobsService::Pause(grpc::ServerContext* context,
                                const v1::PauseJobRequest* request,
                                v1::Job* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (grpc::Status s = CheckJobId(request->job_id()); !s.ok()) return s;
  return Reply(engine_.Pause(request->job_id()), response);
}

grpc::Status JobsService::Resume(grpc::ServerContext* context,
                                 const v1::ResumeJobRequest* request,
                                 v1::Job* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (grpc::Status s = CheckJobId(request->job_id()); !s.ok()) return s;
  return Reply(engine_.Resume(request->job_id()), response);
}

grpc::Status JobsService::Cancel(grpc::ServerContext* context,
                                 const v1::CancelJobRequest* request,
                                 v1::Job* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (grpc::Status s = CheckJobId(request->job_id()); !s.ok()) return s;
  return Reply(engine_.Cancel(request->job_id()), response);
}

grpc::Status JobsService::Continue(grpc::ServerContext* context,
                                   const v1::ContinueJobRequest* request,
                                   v1::Job* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (grpc::Status s = CheckJobId(request->job_id()); !s.ok()) return s;
  return Reply(engine_.Continue(request->job_id()), response);
}

}  // namespace hdrstereo::rpc
