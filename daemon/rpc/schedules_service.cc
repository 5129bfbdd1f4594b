// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/schedules_service.h"

#include <google/protobuf/util/time_util.h>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "daemon/jobs/capture_job.h"
#include "daemon/jobs/cron.h"
#include "daemon/rpc/pagination.h"
#include "daemon/rpc/status.h"
#include "daemon/store/names.h"

namespace hdrstereo::rpc {
namespace {

using google::protobuf::util::TimeUtil;

v1::ScheduleRun::Outcome OutcomeToProto(store::RunOutcome outcome) {
  switch (outcome) {
    case store::RunOutcome::kRunning:
      return v1::ScheduleRun::OUTCOME_RUNNING;
    case store::RunOutcome::kSucceeded:
      return v1::ScheduleRun::OUTCOME_SUCCEEDED;
    case store::RunOutcome::kFailed:
      return v1::ScheduleRun::OUTCOME_FAILED;
    case store::RunOutcome::kSkipped:
      return v1::ScheduleRun::OUTCOME_SKIPPED;
  }
  return v1::ScheduleRun::OUTCOME_UNSPECIFIED;
}

grpc::Status CheckName(const std::string& name) {
  return ToGrpcStatus(store::ValidateName(name, "name"));
}

}  // namespace

void SchedulesService::ToProto(const store::ScheduleRecord& record,
                               v1::Schedule* out) {
  out->set_name(record.name);
  out->set_cron(record.cron);
  out->set_time_zone(record.time_zone.empty() ? "UTC" : record.time_zone);
  out->set_enabled(record.enabled);
  out->mutable_plan()->ParseFromString(record.plan);
  out->set_missed_run_policy(record.missed_run_policy ==
                                     store::MissedRunPolicy::kSkip
                                 ? v1::MISSED_RUN_POLICY_SKIP
                                 : v1::MISSED_RUN_POLICY_RUN_ONCE_ON_START);
  if (std::optional<absl::Time> next = scheduler_.NextDue(record)) {
    *out->mutable_next_due_time() =
        TimeUtil::MillisecondsToTimestamp(absl::ToUnixMillis(*next));
  }
  *out->mutable_create_time() =
      TimeUtil::MillisecondsToTimestamp(record.create_time_ms);
  out->set_created_by(record.created_by);
}

grpc::Status SchedulesService::Create(grpc::ServerContext* context,
                                      const v1::CreateScheduleRequest* request,
                                      v1::Schedule* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (!request->has_schedule()) return InvalidArgument("schedule is required");
  const v1::Schedule& schedule = request->schedule();
  if (absl::Status s = store::ValidateName(schedule.name(), "schedule.name");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  absl::StatusOr<absl::TimeZone> zone = jobs::LoadZone(schedule.time_zone());
  if (!zone.ok()) {
    return InvalidArgument(
        absl::StrCat("schedule.time_zone: ", zone.status().message()));
  }
  absl::StatusOr<jobs::CronSchedule> cron =
      jobs::CronSchedule::Parse(schedule.cron(), *zone);
  if (!cron.ok()) {
    return InvalidArgument(
        absl::StrCat("schedule.cron: ", cron.status().message()));
  }
  if (!cron->NextAfter(scheduler_.Now()).has_value()) {
    return InvalidArgument(absl::StrCat("schedule.cron \"", schedule.cron(),
                                        "\" is never due after now"));
  }
  if (schedule.next_due_time().seconds() != 0 ||
      schedule.create_time().seconds() != 0 || !schedule.created_by().empty()) {
    return InvalidArgument(
        "schedule.next_due_time, schedule.create_time and schedule.created_by "
        "are output only");
  }
  absl::StatusOr<jobs::RigLimits> limits = jobs::LimitsOf(rig_);
  if (!limits.ok()) return ToGrpcStatus(limits.status());
  if (absl::Status s =
          jobs::ValidateSchedulePlan(schedule.plan(), schedule.name(), *limits);
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  store::ScheduleRecord record;
  record.created_by = caller.principal.name;
  record.name = schedule.name();
  record.cron = schedule.cron();
  record.time_zone = schedule.time_zone();
  record.enabled = true;  // a new schedule is enabled; disable it after
  record.plan = schedule.plan().SerializeAsString();
  switch (schedule.missed_run_policy()) {
    case v1::MISSED_RUN_POLICY_UNSPECIFIED:
    case v1::MISSED_RUN_POLICY_RUN_ONCE_ON_START:
      record.missed_run_policy = store::MissedRunPolicy::kRunOnceOnStart;
      break;
    case v1::MISSED_RUN_POLICY_SKIP:
      record.missed_run_policy = store::MissedRunPolicy::kSkip;
      break;
    default:
      return InvalidArgument(absl::StrCat(
          "schedule.missed_run_policy ",
          static_cast<int>(schedule.missed_run_policy()), " is not a policy"));
  }
  absl::StatusOr<store::ScheduleRecord> created =
      scheduler_.repository().Create(record,
                                     absl::ToUnixMillis(scheduler_.Now()));
  if (!created.ok()) return ToGrpcStatus(created.status());
  scheduler_.Wake();
  ToProto(*created, response);
  return grpc::Status::OK;
}

grpc::Status SchedulesService::List(grpc::ServerContext* context,
                                    const v1::ListSchedulesRequest* request,
                                    v1::ListSchedulesResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  absl::StatusOr<Page> page = ParsePage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  absl::StatusOr<std::vector<store::ScheduleRecord>> schedules =
      scheduler_.repository().List(page->after, page->size + 1);
  if (!schedules.ok()) return ToGrpcStatus(schedules.status());
  if (static_cast<int>(schedules->size()) > page->size) {
    schedules->pop_back();
    response->set_next_page_token(EncodePageToken(schedules->back().name));
  }
  for (const store::ScheduleRecord& s : *schedules) {
    ToProto(s, response->add_schedules());
  }
  return grpc::Status::OK;
}

grpc::Status SchedulesService::Delete(grpc::ServerContext* context,
                                      const v1::DeleteScheduleRequest* request,
                                      v1::DeleteScheduleResponse*) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (grpc::Status s = CheckName(request->name()); !s.ok()) return s;
  return ToGrpcStatus(scheduler_.repository().Delete(request->name()));
}

grpc::Status SchedulesService::SetEnabled(
    grpc::ServerContext* context, const v1::SetScheduleEnabledRequest* request,
    v1::Schedule* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (grpc::Status s = CheckName(request->name()); !s.ok()) return s;
  absl::StatusOr<store::ScheduleRecord> record =
      scheduler_.repository().SetEnabled(request->name(), request->enabled(),
                                         absl::ToUnixMillis(scheduler_.Now()),
                                         caller.principal.name);
  if (!record.ok()) return ToGrpcStatus(record.status());
  scheduler_.Wake();
  ToProto(*record, response);
  return grpc::Status::OK;
}

grpc::Status SchedulesService::ListRuns(
    grpc::ServerContext* context, const v1::ListScheduleRunsRequest* request,
    v1::ListScheduleRunsResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (grpc::Status s = CheckName(request->name()); !s.ok()) return s;
  absl::StatusOr<IdPage> page = ParseIdPage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  absl::StatusOr<std::vector<store::ScheduleRunRecord>> runs =
      scheduler_.repository().Runs(request->name(), page->after,
                                   page->size + 1);
  if (!runs.ok()) return ToGrpcStatus(runs.status());
  response->set_next_page_token(FinishIdPage(
      *page, *runs,
      [](const store::ScheduleRunRecord& run) { return run.due_time_ms; }));
  for (const store::ScheduleRunRecord& run : *runs) {
    v1::ScheduleRun* out = response->add_runs();
    out->set_schedule(run.schedule);
    *out->mutable_due_time() =
        TimeUtil::MillisecondsToTimestamp(run.due_time_ms);
    if (run.start_time_ms) {
      *out->mutable_start_time() =
          TimeUtil::MillisecondsToTimestamp(*run.start_time_ms);
    }
    out->set_session(run.session);
    for (int64_t id : run.job_ids) out->add_job_ids(id);
    out->set_outcome(OutcomeToProto(run.outcome));
    out->set_reason(run.reason);
    out->set_caused_by(run.caused_by);
  }
  return grpc::Status::OK;
}

}  // namespace hdrstereo::rpc
