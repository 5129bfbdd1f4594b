// SPDX-License-Identifier: GPL-3.0-or-later
//
// What hdrstereod tells webhooks: the event types, which job events and
// schedule runs are one, the JSON body, the hook URLs and event filters an
// admin may configure, and the retry schedule. Pure functions; the
// dispatcher (webhook_dispatcher.h) sends.
#ifndef HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_EVENTS_H_
#define HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_EVENTS_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "daemon/store/job_repository.h"
#include "daemon/store/schedule_repository.h"

namespace hdrstereo::notify {

// Every event type, as sent in the body's "type" and the event header:
// job.succeeded, job.failed, job.cancelled (a job's final state),
// job.suspended, job.resumed (a condition paused it / it resumed by
// itself), schedule_run.succeeded, schedule_run.failed,
// schedule_run.skipped.
const std::vector<std::string>& EventTypes();

// The event a job event is, if any: a job's final state (once, not the
// events recorded after it), a suspension ("suspended: ...") and an
// automatic resumption ("resumed: ..."). Pauses by a person are not events.
std::optional<std::string> JobEventType(const store::JobEventRow& row);
std::string ScheduleRunEventType(const store::ScheduleRunRecord& run);

// The id a receiver deduplicates on: the same for every hook and attempt.
std::string JobEventId(const store::JobEventRow& row);
std::string ScheduleRunEventId(const store::ScheduleRunRecord& run);

// JSON bodies: {"id", "type", "time" (RFC 3339, UTC), "daemon" (host name),
// and "job" or "schedule_run" with what a person needs to act}.
std::string JobEventBody(const store::JobEventRow& row, absl::string_view type,
                         absl::string_view daemon_host);
std::string ScheduleRunBody(const store::ScheduleRunRecord& run,
                            absl::string_view daemon_host);

// An event filter: each entry an event type or "job.*" / "schedule_run.*";
// empty means every event. Returns it without duplicates, or
// INVALID_ARGUMENT naming the entry that is none of these.
absl::StatusOr<std::vector<std::string>> ValidateEventFilter(
    const std::vector<std::string>& filter);
bool FilterMatches(const std::vector<std::string>& filter,
                   absl::string_view type);

// An absolute http:// or https:// URL with a host and no user name or
// password in it (those would be stored and shown); at most 2048 bytes.
// INVALID_ARGUMENT says which rule the URL breaks.
absl::Status ValidateWebhookUrl(absl::string_view url);
// "https://hooks.example.org:8443": what logs show of a URL (its path and
// query may carry a token).
std::string UrlOrigin(absl::string_view url);

struct RetryPolicy {
  int max_attempts = 8;
  absl::Duration first_retry = absl::Seconds(5);  // doubles per attempt
  absl::Duration max_retry = absl::Minutes(10);
};

// The delay before attempt `failed_attempts + 1`, or nullopt when the
// policy gives up. A response that says the request itself is wrong (4xx
// other than 408 and 429) is not retried.
std::optional<absl::Duration> RetryDelay(const RetryPolicy& policy,
                                         int failed_attempts, int http_status);

}  // namespace hdrstereo::notify

#endif  // HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_EVENTS_H_
