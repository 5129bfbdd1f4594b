// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/webhook_repository.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::store {
namespace {

constexpr char kSelectHook[] = R"sql(
SELECT h.id, h.url, h.events, h.salt, h.note, h.created_by, h.create_time_ms,
  (SELECT count(*) FROM webhook_events e
   WHERE e.webhook_id = h.id AND e.state = 'pending'),
  (SELECT count(*) FROM webhook_events e
   WHERE e.webhook_id = h.id AND e.state = 'delivered'),
  (SELECT count(*) FROM webhook_events e
   WHERE e.webhook_id = h.id AND e.state = 'abandoned'),
  d.time_ms, d.http_status, d.error
FROM webhooks h
LEFT JOIN webhook_deliveries d ON d.id = (
  SELECT max(d2.id) FROM webhook_deliveries d2
  JOIN webhook_events e2 ON e2.id = d2.webhook_event_id
  WHERE e2.webhook_id = h.id)
)sql";

WebhookRecord ReadHook(const Statement& stmt) {
  WebhookRecord h;
  h.id = stmt.ColumnInt(0);
  h.url = stmt.ColumnText(1);
  h.events = absl::StrSplit(stmt.ColumnText(2), ',', absl::SkipEmpty());
  h.salt_hex = stmt.ColumnText(3);
  h.note = stmt.ColumnText(4);
  h.created_by = stmt.ColumnText(5);
  h.create_time_ms = stmt.ColumnInt(6);
  h.pending = stmt.ColumnInt(7);
  h.delivered = stmt.ColumnInt(8);
  h.abandoned = stmt.ColumnInt(9);
  if (!stmt.ColumnIsNull(10)) {
    h.last_attempt_time_ms = stmt.ColumnInt(10);
    h.last_http_status = static_cast<int>(stmt.ColumnInt(11));
    h.last_error = stmt.ColumnText(12);
  }
  return h;
}

absl::StatusOr<WebhookRecord> GetLocked(Database& db, int64_t id)
    ABSL_EXCLUSIVE_LOCKS_REQUIRED(db.mutex()) {
  ASSIGN_OR_RETURN(Statement stmt,
                   db.Prepare(absl::StrCat(kSelectHook, "WHERE h.id = ?1")));
  stmt.Bind(1, id);
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row) {
    return absl::NotFoundError(absl::StrCat(
        "no webhook ", id, " (`hdrstereo admin webhook list` shows them)"));
  }
  return ReadHook(stmt);
}

OutboxState ParseOutboxState(const std::string& text) {
  if (text == "delivered") return OutboxState::kDelivered;
  if (text == "abandoned") return OutboxState::kAbandoned;
  return OutboxState::kPending;
}

}  // namespace

const char* OutboxStateName(OutboxState state) {
  switch (state) {
    case OutboxState::kPending:
      return "pending";
    case OutboxState::kDelivered:
      return "delivered";
    case OutboxState::kAbandoned:
      return "abandoned";
  }
  return "pending";
}

absl::StatusOr<WebhookRecord> WebhookRepository::Create(
    const WebhookRecord& hook) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(
      Statement insert,
      db.Prepare("INSERT INTO webhooks (url, events, salt, note, created_by, "
                 "create_time_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?6)"));
  RETURN_IF_ERROR(insert.Bind(1, hook.url)
                      .Bind(2, absl::StrJoin(hook.events, ","))
                      .Bind(3, hook.salt_hex)
                      .Bind(4, hook.note)
                      .Bind(5, hook.created_by)
                      .Bind(6, hook.create_time_ms)
                      .Run());
  ASSIGN_OR_RETURN(WebhookRecord created, GetLocked(db, db.LastInsertId()));
  RETURN_IF_ERROR(tx.Commit());
  return created;
}

absl::StatusOr<WebhookRecord> WebhookRepository::Get(int64_t id) {
  absl::MutexLock lock(&store_.db().mutex());
  return GetLocked(store_.db(), id);
}

absl::StatusOr<std::vector<WebhookRecord>> WebhookRepository::List() {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt, store_.db().Prepare(absl::StrCat(
                                       kSelectHook, "ORDER BY h.id")));
  std::vector<WebhookRecord> hooks;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    hooks.push_back(ReadHook(stmt));
  }
  return hooks;
}

absl::StatusOr<WebhookRecord> WebhookRepository::Delete(int64_t id) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(WebhookRecord hook, GetLocked(db, id));
  ASSIGN_OR_RETURN(Statement remove,
                   db.Prepare("DELETE FROM webhooks WHERE id = ?1"));
  RETURN_IF_ERROR(remove.Bind(1, id).Run());
  RETURN_IF_ERROR(tx.Commit());
  return hook;
}

absl::StatusOr<int64_t> WebhookRepository::JobEventCursor() {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  ASSIGN_OR_RETURN(Statement newest,
                   db.Prepare("SELECT coalesce(max(id), 0) FROM job_events"));
  ASSIGN_OR_RETURN(bool has_newest, newest.Step());
  const int64_t newest_id = has_newest ? newest.ColumnInt(0) : 0;
  ASSIGN_OR_RETURN(
      Statement read,
      db.Prepare("SELECT job_event_id FROM notification_cursor WHERE id = 1"));
  ASSIGN_OR_RETURN(bool has_cursor, read.Step());
  int64_t cursor = has_cursor ? read.ColumnInt(0) : newest_id;
  // Row ids of deleted newest events (a deleted session) are handed out
  // again: a cursor beyond the newest row would skip their successors.
  cursor = std::min(cursor, newest_id);
  ASSIGN_OR_RETURN(Statement write,
                   db.Prepare("INSERT INTO notification_cursor (id, "
                              "job_event_id) VALUES (1, ?1) ON CONFLICT (id) "
                              "DO UPDATE SET job_event_id = ?1"));
  RETURN_IF_ERROR(write.Bind(1, cursor).Run());
  RETURN_IF_ERROR(tx.Commit());
  return cursor;
}

absl::Status WebhookRepository::Enqueue(
    const std::vector<OutboxEntry>& entries, int64_t job_event_cursor,
    const std::vector<int64_t>& announced_runs, int64_t now_ms) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  for (const OutboxEntry& entry : entries) {
    // A hook deleted since the caller listed the hooks drops its entry.
    ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT OR IGNORE INTO webhook_events (webhook_id, event_id, type, body, state,
                                      next_attempt_time_ms, create_time_ms)
SELECT ?1, ?2, ?3, ?4, 'pending', ?5, ?5 WHERE EXISTS (
  SELECT 1 FROM webhooks WHERE id = ?1))sql"));
    RETURN_IF_ERROR(insert.Bind(1, entry.webhook_id)
                        .Bind(2, entry.event_id)
                        .Bind(3, entry.type)
                        .Bind(4, entry.body)
                        .Bind(5, now_ms)
                        .Run());
  }
  ASSIGN_OR_RETURN(Statement cursor,
                   db.Prepare("UPDATE notification_cursor SET job_event_id = "
                              "max(job_event_id, ?1) WHERE id = 1"));
  RETURN_IF_ERROR(cursor.Bind(1, job_event_cursor).Run());
  for (int64_t run : announced_runs) {
    ASSIGN_OR_RETURN(
        Statement mark,
        db.Prepare("UPDATE schedule_runs SET announced = 1 WHERE id = ?1"));
    RETURN_IF_ERROR(mark.Bind(1, run).Run());
  }
  return tx.Commit();
}

absl::StatusOr<std::vector<DueDelivery>> WebhookRepository::Due(int64_t now_ms,
                                                                int limit) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt, store_.db().Prepare(R"sql(
SELECT e.id, e.webhook_id, h.url, h.salt, e.event_id, e.type, e.body,
       e.attempts
FROM webhook_events e JOIN webhooks h ON h.id = e.webhook_id
WHERE e.state = 'pending' AND e.next_attempt_time_ms <= ?1
ORDER BY e.next_attempt_time_ms, e.id LIMIT ?2)sql"));
  stmt.Bind(1, now_ms).Bind(2, int64_t{limit});
  std::vector<DueDelivery> due;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    due.push_back({.outbox_id = stmt.ColumnInt(0),
                   .webhook_id = stmt.ColumnInt(1),
                   .url = stmt.ColumnText(2),
                   .salt_hex = stmt.ColumnText(3),
                   .event_id = stmt.ColumnText(4),
                   .type = stmt.ColumnText(5),
                   .body = stmt.ColumnText(6),
                   .attempts = static_cast<int>(stmt.ColumnInt(7))});
  }
  return due;
}

absl::StatusOr<std::optional<int64_t>> WebhookRepository::NextDue() {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt,
                   store_.db().Prepare("SELECT min(next_attempt_time_ms) FROM "
                                       "webhook_events WHERE state = "
                                       "'pending'"));
  ASSIGN_OR_RETURN(bool row, stmt.Step());
  if (!row || stmt.ColumnIsNull(0)) return std::nullopt;
  return stmt.ColumnInt(0);
}

absl::Status WebhookRepository::RecordAttempt(
    const DueDelivery& delivery, int64_t time_ms, int64_t duration_ms,
    int http_status, absl::string_view error, OutboxState state,
    int64_t next_attempt_ms) {
  Database& db = store_.db();
  Transaction tx(db);
  RETURN_IF_ERROR(tx.status());
  // The hook may have been deleted while the request was out.
  ASSIGN_OR_RETURN(Statement exists,
                   db.Prepare("SELECT 1 FROM webhook_events WHERE id = ?1"));
  exists.Bind(1, delivery.outbox_id);
  ASSIGN_OR_RETURN(bool present, exists.Step());
  if (!present) return absl::OkStatus();
  ASSIGN_OR_RETURN(Statement insert, db.Prepare(R"sql(
INSERT INTO webhook_deliveries (webhook_event_id, attempt, time_ms,
                                duration_ms, http_status, error)
VALUES (?1, ?2, ?3, ?4, ?5, ?6))sql"));
  RETURN_IF_ERROR(insert.Bind(1, delivery.outbox_id)
                      .Bind(2, int64_t{delivery.attempts + 1})
                      .Bind(3, time_ms)
                      .Bind(4, duration_ms)
                      .Bind(5, int64_t{http_status})
                      .Bind(6, error)
                      .Run());
  ASSIGN_OR_RETURN(Statement update, db.Prepare(R"sql(
UPDATE webhook_events SET attempts = ?2, state = ?3, next_attempt_time_ms = ?4
WHERE id = ?1)sql"));
  RETURN_IF_ERROR(update.Bind(1, delivery.outbox_id)
                      .Bind(2, int64_t{delivery.attempts + 1})
                      .Bind(3, OutboxStateName(state))
                      .Bind(4, next_attempt_ms)
                      .Run());
  return tx.Commit();
}

absl::StatusOr<std::vector<DeliveryAttempt>> WebhookRepository::Attempts(
    int64_t webhook_id, int64_t before_id, int limit) {
  absl::MutexLock lock(&store_.db().mutex());
  ASSIGN_OR_RETURN(Statement stmt, store_.db().Prepare(R"sql(
SELECT d.id, e.webhook_id, e.event_id, e.type, d.attempt, d.time_ms,
       d.duration_ms, d.http_status, d.error, e.state
FROM webhook_deliveries d JOIN webhook_events e ON e.id = d.webhook_event_id
WHERE e.webhook_id = ?1 AND (?2 = 0 OR d.id < ?2)
ORDER BY d.id DESC LIMIT ?3)sql"));
  stmt.Bind(1, webhook_id).Bind(2, before_id).Bind(3, int64_t{limit});
  std::vector<DeliveryAttempt> attempts;
  while (true) {
    ASSIGN_OR_RETURN(bool row, stmt.Step());
    if (!row) break;
    attempts.push_back({.id = stmt.ColumnInt(0),
                        .webhook_id = stmt.ColumnInt(1),
                        .event_id = stmt.ColumnText(2),
                        .type = stmt.ColumnText(3),
                        .attempt = static_cast<int>(stmt.ColumnInt(4)),
                        .time_ms = stmt.ColumnInt(5),
                        .duration_ms = stmt.ColumnInt(6),
                        .http_status = static_cast<int>(stmt.ColumnInt(7)),
                        .error = stmt.ColumnText(8),
                        .event_state = ParseOutboxState(stmt.ColumnText(9))});
  }
  return attempts;
}

}  // namespace hdrstereo::store
