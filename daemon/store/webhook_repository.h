// SPDX-License-Identifier: GPL-3.0-or-later
//
// Webhooks and their outbox (tables `webhooks`, `webhook_events`,
// `webhook_deliveries`, `notification_cursor`). The outbox is filled from
// what the store already records (job events after a cursor, schedule runs
// not yet announced) in the transaction that advances the cursor, so an
// event is neither lost nor queued twice across a crash or restart.
#ifndef HDRSTEREO_DAEMON_STORE_WEBHOOK_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_WEBHOOK_REPOSITORY_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

struct WebhookRecord {
  int64_t id = 0;
  std::string url;
  std::vector<std::string> events;  // the filter; empty = every event
  std::string salt_hex;             // of the derived signing secret
  std::string note;
  std::string created_by;
  int64_t create_time_ms = 0;
  // Its outbox so far.
  int64_t pending = 0;
  int64_t delivered = 0;
  int64_t abandoned = 0;
  std::optional<int64_t> last_attempt_time_ms;
  int last_http_status = 0;  // 0: no response (or no attempt yet)
  std::string last_error;
};

// One event queued for one hook.
struct OutboxEntry {
  int64_t webhook_id = 0;
  std::string event_id;  // the same for every hook and attempt
  std::string type;      // e.g. "job.failed"
  std::string body;      // JSON
};

// A queued event due for an attempt, with what sending it needs.
struct DueDelivery {
  int64_t outbox_id = 0;
  int64_t webhook_id = 0;
  std::string url;
  std::string salt_hex;
  std::string event_id;
  std::string type;
  std::string body;
  int attempts = 0;  // made so far
};

enum class OutboxState { kPending, kDelivered, kAbandoned };
const char* OutboxStateName(OutboxState state);

// One attempt, as recorded.
struct DeliveryAttempt {
  int64_t id = 0;
  int64_t webhook_id = 0;
  std::string event_id;
  std::string type;
  int attempt = 0;  // 1-based
  int64_t time_ms = 0;
  int64_t duration_ms = 0;
  int http_status = 0;  // 0: no response
  std::string error;
  OutboxState event_state = OutboxState::kPending;  // the event's state now
};

class WebhookRepository {
 public:
  explicit WebhookRepository(Store& store) : store_(store) {}

  absl::StatusOr<WebhookRecord> Create(const WebhookRecord& hook);
  // NOT_FOUND names the id.
  absl::StatusOr<WebhookRecord> Get(int64_t id);
  // Oldest first, with their outbox counts.
  absl::StatusOr<std::vector<WebhookRecord>> List();
  // Deletes the hook with its queued events and delivery history; NOT_FOUND
  // names the id.
  absl::StatusOr<WebhookRecord> Delete(int64_t id);

  // The row id (job_events.id) of the last job event handed to the outbox.
  // The first call on a database starts it at the newest event: history
  // from before notifications existed is not sent.
  absl::StatusOr<int64_t> JobEventCursor();
  // In one transaction: queues `entries` (an entry already queued for its
  // hook is kept as it is), moves the job-event cursor to `job_event_cursor`
  // and marks `announced_runs` announced.
  absl::Status Enqueue(const std::vector<OutboxEntry>& entries,
                       int64_t job_event_cursor,
                       const std::vector<int64_t>& announced_runs,
                       int64_t now_ms);

  // Pending events whose next attempt is due at `now_ms`, oldest first.
  absl::StatusOr<std::vector<DueDelivery>> Due(int64_t now_ms, int limit);
  // The earliest next attempt of a pending event; nullopt when none.
  absl::StatusOr<std::optional<int64_t>> NextDue();
  // Records one attempt and the event's state after it (`next_attempt_ms`
  // applies to kPending).
  absl::Status RecordAttempt(const DueDelivery& delivery, int64_t time_ms,
                             int64_t duration_ms, int http_status,
                             absl::string_view error, OutboxState state,
                             int64_t next_attempt_ms);
  // Attempts at one hook's deliveries, newest first, ids below `before_id`
  // (0 = from the newest).
  absl::StatusOr<std::vector<DeliveryAttempt>> Attempts(int64_t webhook_id,
                                                        int64_t before_id,
                                                        int limit);

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_WEBHOOK_REPOSITORY_H_
