// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/scheduler.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <set>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "daemon/store/job_repository.h"
#include "daemon/store/names.h"
#include "daemon/store/session_repository.h"
#include "processing/base/status_macros.h"
#include "processing/pipeline/pipeline.h"

namespace hdrstereo::jobs {
namespace {

constexpr int kMaxCatchUp = 100000;  // due times counted when catching up

std::string FormatDue(absl::Time t, absl::TimeZone zone) {
  return absl::FormatTime("%Y-%m-%d %H:%M %Z", t, zone);
}

// The principal a schedule's runs are for.
std::string CauseOf(const store::ScheduleRecord& schedule) {
  return schedule.enabled_by.empty() ? schedule.created_by
                                     : schedule.enabled_by;
}

std::string FormatLateness(absl::Duration d) {
  const int64_t minutes = absl::ToInt64Minutes(d);
  if (minutes < 120) return absl::StrCat(minutes, " min");
  return absl::StrCat(minutes / 60, " h ", minutes % 60, " min");
}

}  // namespace

absl::StatusOr<std::string> ExpandSessionPattern(absl::string_view pattern,
                                                 absl::string_view schedule,
                                                 absl::Time due,
                                                 absl::TimeZone zone) {
  std::string text = pattern.empty() ? absl::StrCat(schedule, "-{date}-{time}")
                                     : std::string(pattern);
  text = absl::StrReplaceAll(
      text, {{"{date}", absl::FormatTime("%Y-%m-%d", due, zone)},
             {"{time}", absl::FormatTime("%H%M", due, zone)}});
  if (text.find_first_of("{}") != std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("plan.session_pattern \"", pattern,
                     "\" has a placeholder other than {date} and {time}"));
  }
  if (absl::Status s = store::ValidateName(text, "plan.session_pattern");
      !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("plan.session_pattern \"",
                                                   pattern, "\" expands to \"",
                                                   text, "\": ", s.message()));
  }
  return text;
}

absl::Status ValidateSchedulePlan(const v1::SchedulePlan& plan,
                                  absl::string_view schedule,
                                  const RigLimits& limits) {
  if (plan.captures().empty()) {
    return absl::InvalidArgumentError(
        "plan.captures is empty: a schedule needs at least one capture");
  }
  for (int i = 0; i < plan.captures_size(); ++i) {
    if (plan.captures(i).has_calibration()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "plan.captures[", i,
          "] is a calibration: a schedule never runs one (it waits for an "
          "operator to place the board before each pose); run it with "
          "`hdrstereo capture calibration`"));
    }
    absl::StatusOr<v1::CapturePlan> normal =
        NormalizePlan(plan.captures(i), limits);
    if (!normal.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("plan.captures[", i, "]: ", normal.status().message()));
    }
  }
  if (!plan.processing_steps().empty()) {
    if (absl::StatusOr<std::vector<std::string>> steps = pipeline::ResolveSteps(
            {plan.processing_steps().begin(), plan.processing_steps().end()});
        !steps.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("plan.processing_steps: ", steps.status().message()));
    }
  }
  return ExpandSessionPattern(plan.session_pattern(), schedule,
                              absl::UnixEpoch(), absl::UTCTimeZone())
      .status();
}

Scheduler::Scheduler(store::Store& store, CaptureSubmitter submit,
                     ProcessingSubmitter submit_processing,
                     SchedulerOptions options)
    : store_(store),
      schedules_(store),
      submit_(std::move(submit)),
      submit_processing_(std::move(submit_processing)),
      options_(std::move(options)) {}

Scheduler::~Scheduler() { Stop(); }

absl::Status Scheduler::Start() {
  {
    absl::MutexLock tick(&tick_mutex_);
    // A run recorded without jobs was cut off while it started them.
    ASSIGN_OR_RETURN(std::vector<store::ScheduleRunRecord> running,
                     schedules_.RunningRuns());
    for (store::ScheduleRunRecord& run : running) {
      if (!run.job_ids.empty()) continue;
      run.outcome = store::RunOutcome::kFailed;
      run.reason = "hdrstereod stopped while the run was starting its jobs";
      run.end_time_ms = absl::ToUnixMillis(Now());
      RETURN_IF_ERROR(schedules_.UpdateRun(run));
    }
  }
  thread_ = std::thread([this] { Loop(); });
  return absl::OkStatus();
}

void Scheduler::Loop() {
  while (true) {
    {
      absl::MutexLock lock(&mutex_);
      if (stopping_) return;
    }
    if (absl::Status s = Tick(); !s.ok()) {
      spdlog::warn("scheduler: {}", std::string(s.message()));
    }
    absl::MutexLock lock(&mutex_);
    const absl::Time deadline = absl::Now() + options_.tick;
    while (!stopping_ && !wake_) {
      if (cv_.WaitWithDeadline(&mutex_, deadline)) break;  // timed out
    }
    wake_ = false;
  }
}

void Scheduler::Stop() {
  {
    absl::MutexLock lock(&mutex_);
    stopping_ = true;
    cv_.SignalAll();
  }
  if (thread_.joinable()) thread_.join();
}

void Scheduler::Wake() {
  absl::MutexLock lock(&mutex_);
  wake_ = true;
  cv_.SignalAll();
}

std::optional<absl::Time> Scheduler::NextDue(
    const store::ScheduleRecord& schedule) {
  if (!schedule.enabled) return std::nullopt;
  absl::StatusOr<absl::TimeZone> zone = LoadZone(schedule.time_zone);
  if (!zone.ok()) return std::nullopt;
  absl::StatusOr<CronSchedule> cron = CronSchedule::Parse(schedule.cron, *zone);
  if (!cron.ok()) return std::nullopt;
  absl::Time after = std::max(
      Now(), absl::FromUnixMillis(std::max(
                 schedule.enable_time_ms,
                 schedule.last_due_time_ms.value_or(schedule.enable_time_ms))));
  return cron->NextAfter(after);
}

absl::Status Scheduler::SettleRunning() {
  ASSIGN_OR_RETURN(std::vector<store::ScheduleRunRecord> running,
                   schedules_.RunningRuns());
  store::JobRepository jobs(store_);
  for (store::ScheduleRunRecord& run : running) {
    if (run.job_ids.empty()) continue;  // being started, or see Start()
    bool final = true;
    std::string failure;
    int64_t end_ms = 0;
    for (int64_t id : run.job_ids) {
      absl::StatusOr<store::JobRecord> job = jobs.Get(id);
      if (!job.ok()) {
        if (failure.empty()) {
          failure = absl::StrCat("job ", id, ": ", job.status().message());
        }
        continue;
      }
      // Interrupted jobs are queued again at start-up unless the daemon
      // runs with --resume-interrupted false; then they stay interrupted
      // and would block the schedule forever, so they end the run.
      if (!store::IsFinal(job->state) &&
          job->state != store::JobState::kInterrupted) {
        final = false;
        break;
      }
      end_ms = std::max(end_ms, job->end_time_ms.value_or(0));
      if (job->state != store::JobState::kSucceeded && failure.empty()) {
        failure = absl::StrCat("job ", id, " ", store::JobStateName(job->state),
                               job->error.empty() ? "" : ": ", job->error);
      }
    }
    if (!final) continue;
    run.outcome = failure.empty() ? store::RunOutcome::kSucceeded
                                  : store::RunOutcome::kFailed;
    if (!failure.empty()) {
      run.reason = run.reason.empty() ? failure
                                      : absl::StrCat(run.reason, "; ", failure);
    }
    run.end_time_ms = end_ms > 0 ? end_ms : absl::ToUnixMillis(Now());
    RETURN_IF_ERROR(schedules_.UpdateRun(run));
    spdlog::info("schedule {}: run of session {} {}", run.schedule, run.session,
                 store::RunOutcomeName(run.outcome));
  }
  return absl::OkStatus();
}

absl::Status Scheduler::Tick() {
  absl::MutexLock tick(&tick_mutex_);
  const absl::Time now = Now();
  RETURN_IF_ERROR(SettleRunning());
  std::string after;
  while (true) {
    ASSIGN_OR_RETURN(std::vector<store::ScheduleRecord> page,
                     schedules_.List(after, 200));
    for (const store::ScheduleRecord& schedule : page) {
      if (!schedule.enabled) continue;
      if (absl::Status s = HandleSchedule(schedule, now); !s.ok()) {
        spdlog::warn("schedule {}: {}", schedule.name,
                     std::string(s.message()));
      }
    }
    if (page.size() < 200) break;
    after = page.back().name;
  }
  return absl::OkStatus();
}

absl::Status Scheduler::HandleSchedule(const store::ScheduleRecord& schedule,
                                       absl::Time now) {
  ASSIGN_OR_RETURN(absl::TimeZone zone, LoadZone(schedule.time_zone));
  ASSIGN_OR_RETURN(CronSchedule cron, CronSchedule::Parse(schedule.cron, zone));
  const absl::Time anchor = absl::FromUnixMillis(
      std::max(schedule.enable_time_ms,
               schedule.last_due_time_ms.value_or(schedule.enable_time_ms)));
  std::optional<absl::Time> due = cron.NextAfter(anchor);
  if (!due || *due > now) return absl::OkStatus();
  // The newest due time that has come; earlier ones were missed outright.
  int earlier = 0;
  for (int i = 0; i < kMaxCatchUp; ++i) {
    std::optional<absl::Time> next = cron.NextAfter(*due);
    if (!next || *next > now) break;
    due = next;
    ++earlier;
  }
  std::string note;
  if (earlier > 0) {
    note = absl::StrCat(earlier, " earlier due time", earlier == 1 ? "" : "s",
                        " missed without a run");
  }
  const absl::Duration late = now - *due;
  store::ScheduleRunRecord skip;
  skip.schedule_id = schedule.id;
  skip.caused_by = CauseOf(schedule);
  skip.schedule = schedule.name;
  skip.due_time_ms = absl::ToUnixMillis(*due);
  skip.outcome = store::RunOutcome::kSkipped;
  auto join = [&note](std::string reason) {
    return note.empty() ? reason : absl::StrCat(reason, "; ", note);
  };
  if (late > options_.on_time_slack) {
    if (schedule.missed_run_policy == store::MissedRunPolicy::kSkip) {
      skip.reason =
          join(absl::StrCat("missed by ", FormatLateness(late),
                            " (hdrstereod was not running); policy skip"));
      return schedules_.AddRun(skip).status();
    }
    if (late >= options_.max_lateness) {
      skip.reason =
          join(absl::StrCat("missed by ", FormatLateness(late),
                            " (hdrstereod was not running), more than ",
                            FormatLateness(options_.max_lateness),
                            "; policy run-once-on-start "
                            "runs only runs missed by less"));
      return schedules_.AddRun(skip).status();
    }
    note = join(absl::StrCat("started late: missed by ", FormatLateness(late),
                             " (hdrstereod was not running); policy "
                             "run-once-on-start"));
  }
  // Never two runs at once.
  ASSIGN_OR_RETURN(std::vector<store::ScheduleRunRecord> running,
                   schedules_.RunningRuns());
  for (const store::ScheduleRunRecord& run : running) {
    if (run.schedule_id != schedule.id) continue;
    skip.reason = join(absl::StrCat(
        "the run due ", FormatDue(absl::FromUnixMillis(run.due_time_ms), zone),
        " (session ", run.session, ") was still running"));
    spdlog::warn("schedule {}: due {} skipped: {}", schedule.name,
                 FormatDue(*due, zone), skip.reason);
    return schedules_.AddRun(skip).status();
  }
  if (options_.hold) {
    if (absl::Status held = options_.hold(); !held.ok()) {
      skip.reason = join(std::string(held.message()));
      spdlog::warn("schedule {}: due {} skipped: {}", schedule.name,
                   FormatDue(*due, zone), skip.reason);
      return schedules_.AddRun(skip).status();
    }
  }
  return Launch(schedule, cron, *due, now, note);
}

absl::Status Scheduler::Launch(const store::ScheduleRecord& schedule,
                               const CronSchedule& cron, absl::Time due,
                               absl::Time now, std::string note) {
  store::ScheduleRunRecord run;
  run.schedule_id = schedule.id;
  run.schedule = schedule.name;
  run.due_time_ms = absl::ToUnixMillis(due);
  run.start_time_ms = absl::ToUnixMillis(now);
  run.outcome = store::RunOutcome::kRunning;
  run.reason = std::move(note);
  run.caused_by = CauseOf(schedule);
  auto fail = [&](const absl::Status& status) {
    run.outcome = store::RunOutcome::kFailed;
    run.end_time_ms = absl::ToUnixMillis(now);
    run.reason = run.reason.empty()
                     ? std::string(status.message())
                     : absl::StrCat(status.message(), "; ", run.reason);
    spdlog::warn("schedule {}: run due {} failed: {}", schedule.name,
                 FormatDue(due, cron.zone()), run.reason);
    return schedules_.UpdateRun(run);
  };
  v1::SchedulePlan plan;
  absl::StatusOr<std::string> session = absl::InternalError("unparsed plan");
  if (plan.ParseFromString(schedule.plan)) {
    session = ExpandSessionPattern(plan.session_pattern(), schedule.name, due,
                                   cron.zone());
  }
  if (session.ok()) run.session = *session;
  ASSIGN_OR_RETURN(store::ScheduleRunRecord added, schedules_.AddRun(run));
  run = added;
  if (!session.ok()) return fail(session.status());
  store::SessionRepository sessions(store_);
  if (absl::StatusOr<store::SessionRecord> created = sessions.Create(
          *session, absl::StrCat("scheduled by ", schedule.name, " (due ",
                                 FormatDue(due, cron.zone()), ")"));
      !created.ok()) {
    return fail(created.status());
  }
  for (int i = 0; i < plan.captures_size(); ++i) {
    absl::StatusOr<int64_t> job =
        submit_(*session, plan.captures(i), run.caused_by);
    if (!job.ok()) {
      return fail(absl::Status(
          job.status().code(),
          absl::StrCat("capture ", i, ": ", job.status().message())));
    }
    run.job_ids.push_back(*job);
  }
  if (!plan.processing_steps().empty() && submit_processing_) {
    absl::StatusOr<int64_t> job = submit_processing_(
        *session,
        {plan.processing_steps().begin(), plan.processing_steps().end()},
        run.caused_by);
    if (!job.ok()) {
      return fail(
          absl::Status(job.status().code(),
                       absl::StrCat("processing: ", job.status().message())));
    }
    run.job_ids.push_back(*job);
  }
  if (run.job_ids.empty()) {
    run.outcome = store::RunOutcome::kSucceeded;
    run.end_time_ms = absl::ToUnixMillis(now);
  }
  spdlog::info("schedule {}: due {}: session {}, {} job(s)", schedule.name,
               FormatDue(due, cron.zone()), *session, run.job_ids.size());
  return schedules_.UpdateRun(run);
}

}  // namespace hdrstereo::jobs
