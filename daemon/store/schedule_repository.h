// SPDX-License-Identifier: GPL-3.0-or-later
//
// Schedules and their runs (tables `schedules` and `schedule_runs`). The
// plan is stored as given (a serialized v1::SchedulePlan); the store does
// not interpret it.
#ifndef HDRSTEREO_DAEMON_STORE_SCHEDULE_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_SCHEDULE_REPOSITORY_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

enum class MissedRunPolicy { kSkip, kRunOnceOnStart };

struct ScheduleRecord {
  int64_t id = 0;
  std::string name;
  std::string cron;
  std::string time_zone;  // "" = UTC
  bool enabled = true;
  std::string plan;  // serialized v1::SchedulePlan
  MissedRunPolicy missed_run_policy = MissedRunPolicy::kRunOnceOnStart;
  int64_t create_time_ms = 0;
  int64_t enable_time_ms = 0;  // last (re)enabled; create time at first
  std::optional<int64_t> last_due_time_ms;  // newest recorded run
  std::string created_by;                   // principal
  std::string enabled_by;  // principal that last enabled it; its runs' cause
};

enum class RunOutcome { kRunning, kSucceeded, kFailed, kSkipped };
const char* RunOutcomeName(RunOutcome outcome);

struct ScheduleRunRecord {
  int64_t id = 0;
  int64_t schedule_id = 0;
  std::string schedule;
  int64_t due_time_ms = 0;
  std::optional<int64_t> start_time_ms;
  std::optional<int64_t> end_time_ms;
  std::string session;
  std::vector<int64_t> job_ids;
  RunOutcome outcome = RunOutcome::kRunning;
  std::string reason;
  std::string caused_by;  // principal on whose behalf it ran
};

class ScheduleRepository {
 public:
  explicit ScheduleRepository(Store& store) : store_(store) {}

  // INVALID_ARGUMENT for a bad name, ALREADY_EXISTS for a taken one. The
  // caller has validated cron, zone and plan. `created_by` is also stored
  // as `enabled_by`.
  absl::StatusOr<ScheduleRecord> Create(const ScheduleRecord& schedule,
                                        int64_t now_ms);
  absl::StatusOr<ScheduleRecord> Get(absl::string_view name);
  // Ordered by name, after `after`.
  absl::StatusOr<std::vector<ScheduleRecord>> List(absl::string_view after,
                                                   int limit);
  // Removes the schedule and its run history; its sessions stay.
  absl::Status Delete(absl::string_view name);
  // Enabling a disabled schedule sets its enable time (due times before it
  // are not missed runs) and records `by` as the principal its runs are for.
  absl::StatusOr<ScheduleRecord> SetEnabled(absl::string_view name,
                                            bool enabled, int64_t now_ms,
                                            absl::string_view by);

  // Records a run. ALREADY_EXISTS when this due time is already recorded.
  absl::StatusOr<ScheduleRunRecord> AddRun(const ScheduleRunRecord& run);
  absl::Status UpdateRun(const ScheduleRunRecord& run);
  // Ended runs (succeeded, failed, skipped) that notifications have not
  // announced yet (daemon/store/webhook_repository.h), oldest first.
  absl::StatusOr<std::vector<ScheduleRunRecord>> UnannouncedRuns(int limit);
  // Newest due time first, older than `before_due_ms` (0 = from the newest).
  absl::StatusOr<std::vector<ScheduleRunRecord>> Runs(absl::string_view name,
                                                      int64_t before_due_ms,
                                                      int limit);
  // Every run still marked running, of any schedule.
  absl::StatusOr<std::vector<ScheduleRunRecord>> RunningRuns();

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_SCHEDULE_REPOSITORY_H_
