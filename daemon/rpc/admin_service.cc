// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/admin_service.h"

#include <google/protobuf/util/time_util.h>
#include <spdlog/spdlog.h>

#include <algorithm>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "daemon/notify/webhook_events.h"
#include "daemon/rpc/pagination.h"
#include "daemon/rpc/role_proto.h"
#include "daemon/rpc/status.h"

namespace hdrstereo::rpc {
namespace {

using google::protobuf::util::TimeUtil;

void ToProto(const store::ApiKeyRecord& key, v1::ApiKey* out) {
  out->set_id(key.id);
  out->set_user(key.user);
  absl::StatusOr<Role> role = ParseRole(key.role);
  out->set_role(ToProto(role.ok() ? *role : Role::kNone));
  out->set_note(key.note);
  out->set_created_by(key.created_by);
  *out->mutable_create_time() =
      TimeUtil::MillisecondsToTimestamp(key.create_time_ms);
  *out->mutable_expire_time() =
      TimeUtil::MillisecondsToTimestamp(key.expire_time_ms);
  if (key.last_used_time_ms) {
    *out->mutable_last_used_time() =
        TimeUtil::MillisecondsToTimestamp(*key.last_used_time_ms);
  }
  if (key.revoke_time_ms) {
    *out->mutable_revoke_time() =
        TimeUtil::MillisecondsToTimestamp(*key.revoke_time_ms);
  }
}

// A timestamp the caller set, as Unix ms; INVALID_ARGUMENT if out of range.
absl::StatusOr<int64_t> TimeArgument(const google::protobuf::Timestamp& time,
                                     const char* field) {
  // 9999-12-31: the range of google.protobuf.Timestamp.
  if (time.seconds() < 0 || time.seconds() > 253402300799 || time.nanos() < 0 ||
      time.nanos() > 999999999) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, " is not a valid time after 1970"));
  }
  return TimeUtil::TimestampToMilliseconds(time);
}

constexpr size_t kMaxWebhookNoteBytes = 1024;

void ToProto(const store::WebhookRecord& hook, v1::Webhook* out) {
  out->set_id(hook.id);
  out->set_url(hook.url);
  for (const std::string& event : hook.events) out->add_events(event);
  out->set_note(hook.note);
  out->set_created_by(hook.created_by);
  *out->mutable_create_time() =
      TimeUtil::MillisecondsToTimestamp(hook.create_time_ms);
  out->set_pending(hook.pending);
  out->set_delivered(hook.delivered);
  out->set_abandoned(hook.abandoned);
  if (hook.last_attempt_time_ms) {
    *out->mutable_last_attempt_time() =
        TimeUtil::MillisecondsToTimestamp(*hook.last_attempt_time_ms);
  }
  out->set_last_http_status(hook.last_http_status);
  out->set_last_error(hook.last_error);
}

absl::Status ValidateWebhookId(int64_t id) {
  if (id <= 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "webhook id ", id,
        " is not a webhook id (a positive number, as `hdrstereo admin "
        "webhook list` shows)"));
  }
  return absl::OkStatus();
}

}  // namespace

grpc::Status AdminService::CreateApiKey(grpc::ServerContext* context,
                                        const v1::CreateApiKeyRequest* request,
                                        v1::CreateApiKeyResponse* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (absl::Status s = ValidatePrincipalName(request->user(), "user");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  const Role role = FromProto(request->role());
  if (role == Role::kNone) {
    return InvalidArgument(
        "role must be ROLE_VIEWER, ROLE_OPERATOR or "
        "ROLE_ADMIN");
  }
  const Role owner = authenticator_.RoleOf(request->user());
  if (owner == Role::kNone) {
    return InvalidArgument(
        absl::StrCat(request->user(),
                     " has no role in [auth.users] of hdrstereod's config; "
                     "give it one there (and restart) before making it a key"));
  }
  if (role > owner) {
    return InvalidArgument(
        absl::StrCat(request->user(), " is ", RoleName(owner), "; a key for ",
                     request->user(), " can be at most ", RoleName(owner),
                     ", not ", RoleName(role)));
  }
  absl::StatusOr<NewApiKey> key =
      keys_.Create(request->user(), role, absl::Seconds(request->ttl_s()),
                   request->note(), caller.principal.name);
  if (!key.ok()) return ToGrpcStatus(key.status());
  spdlog::info("API key {} created for {} ({}) by {}", key->record.id,
               key->record.user, key->record.role, caller.principal.name);
  ToProto(key->record, response->mutable_key());
  response->set_api_key(key->token);
  return grpc::Status::OK;
}

grpc::Status AdminService::ListApiKeys(grpc::ServerContext* context,
                                       const v1::ListApiKeysRequest* request,
                                       v1::ListApiKeysResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (!request->user().empty()) {
    if (absl::Status s = ValidatePrincipalName(request->user(), "user");
        !s.ok()) {
      return ToGrpcStatus(s);
    }
  }
  absl::StatusOr<Page> page = ParsePage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  std::vector<store::ApiKeyRecord> keys =
      keys_.List(request->user(), request->include_revoked());
  size_t start = 0;
  if (!page->after.empty()) {
    while (start < keys.size() && keys[start].id != page->after) ++start;
    if (start == keys.size()) {
      return InvalidArgument("page.page_token was not issued by this server");
    }
    ++start;
  }
  for (size_t i = start; i < keys.size(); ++i) {
    if (response->keys_size() == page->size) {
      response->set_next_page_token(EncodePageToken(keys[i - 1].id));
      break;
    }
    ToProto(keys[i], response->add_keys());
  }
  return grpc::Status::OK;
}

grpc::Status AdminService::RevokeApiKey(grpc::ServerContext* context,
                                        const v1::RevokeApiKeyRequest* request,
                                        v1::ApiKey* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  const std::string& id = request->id();
  if (id.size() != 12 || !std::all_of(id.begin(), id.end(), [](char c) {
        return absl::ascii_isdigit(c) || (c >= 'a' && c <= 'f');
      })) {
    return InvalidArgument(absl::StrCat(
        "id \"", absl::CHexEscape(id.substr(0, 64)),
        "\" is not a key id (12 hex digits, as `hdrstereo admin key list` "
        "shows)"));
  }
  absl::StatusOr<store::ApiKeyRecord> revoked =
      keys_.Revoke(id, caller.principal.name);
  if (!revoked.ok()) return ToGrpcStatus(revoked.status());
  spdlog::info("API key {} of {} revoked by {}", id, revoked->user,
               caller.principal.name);
  ToProto(*revoked, response);
  return grpc::Status::OK;
}

grpc::Status AdminService::ListAuditLog(grpc::ServerContext* context,
                                        const v1::ListAuditLogRequest* request,
                                        v1::ListAuditLogResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  store::AuditFilter filter;
  if (!request->principal().empty()) {
    if (absl::Status s =
            ValidatePrincipalName(request->principal(), "principal");
        !s.ok()) {
      return ToGrpcStatus(s);
    }
    filter.principal = request->principal();
  }
  if (request->method().size() > 256) {
    return InvalidArgument("method is longer than 256 bytes");
  }
  filter.method = request->method();
  if (request->has_start_time()) {
    absl::StatusOr<int64_t> ms =
        TimeArgument(request->start_time(), "start_time");
    if (!ms.ok()) return ToGrpcStatus(ms.status());
    filter.start_ms = *ms;
  }
  if (request->has_end_time()) {
    absl::StatusOr<int64_t> ms = TimeArgument(request->end_time(), "end_time");
    if (!ms.ok()) return ToGrpcStatus(ms.status());
    filter.end_ms = *ms;
  }
  if (filter.start_ms > 0 && filter.end_ms > 0 &&
      filter.end_ms <= filter.start_ms) {
    return InvalidArgument("end_time must be after start_time");
  }
  absl::StatusOr<IdPage> page = ParseIdPage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  filter.before_id = page->after;
  filter.limit = page->size + 1;
  // Rows of calls made so far are written before they are read.
  audit_.Flush();
  absl::StatusOr<std::vector<store::AuditRecord>> rows =
      audit_.repository().List(filter);
  if (!rows.ok()) return ToGrpcStatus(rows.status());
  response->set_next_page_token(FinishIdPage(
      *page, *rows, [](const store::AuditRecord& row) { return row.id; }));
  for (const store::AuditRecord& row : *rows) {
    v1::AuditEntry* out = response->add_entries();
    out->set_id(row.id);
    *out->mutable_time() = TimeUtil::MillisecondsToTimestamp(row.time_ms);
    out->set_principal(row.principal);
    absl::StatusOr<Role> role = ParseRole(row.role);
    out->set_role(ToProto(role.ok() ? *role : Role::kNone));
    out->set_auth_method(row.auth_method);
    out->set_peer(row.peer);
    out->set_transport(row.transport);
    out->set_method(row.method);
    out->set_subject(row.subject);
    out->set_status_code(row.status_code);
    out->set_message(row.message);
  }
  return grpc::Status::OK;
}

grpc::Status AdminService::CreateWebhook(
    grpc::ServerContext* context, const v1::CreateWebhookRequest* request,
    v1::CreateWebhookResponse* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (absl::Status s = notify::ValidateWebhookUrl(request->url()); !s.ok()) {
    return ToGrpcStatus(s);
  }
  absl::StatusOr<std::vector<std::string>> events = notify::ValidateEventFilter(
      {request->events().begin(), request->events().end()});
  if (!events.ok()) return ToGrpcStatus(events.status());
  if (request->note().size() > kMaxWebhookNoteBytes) {
    return InvalidArgument(
        absl::StrCat("note is longer than ", kMaxWebhookNoteBytes, " bytes"));
  }
  absl::StatusOr<std::string> salt = notify::WebhookSigner::NewSalt();
  if (!salt.ok()) return ToGrpcStatus(salt.status());
  absl::StatusOr<std::string> secret = signer_.SecretFor(*salt);
  if (!secret.ok()) return ToGrpcStatus(secret.status());
  store::WebhookRecord record;
  record.url = request->url();
  record.events = *std::move(events);
  record.salt_hex = *salt;
  record.note = request->note();
  record.created_by = caller.principal.name;
  record.create_time_ms = absl::ToUnixMillis(absl::Now());
  absl::StatusOr<store::WebhookRecord> hook = webhooks_.Create(record);
  if (!hook.ok()) return ToGrpcStatus(hook.status());
  spdlog::info("webhook {} to {} created by {}", hook->id,
               notify::UrlOrigin(hook->url), caller.principal.name);
  ToProto(*hook, response->mutable_webhook());
  response->set_secret(*secret);
  return grpc::Status::OK;
}

grpc::Status AdminService::ListWebhooks(grpc::ServerContext* context,
                                        const v1::ListWebhooksRequest*,
                                        v1::ListWebhooksResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  absl::StatusOr<std::vector<store::WebhookRecord>> hooks = webhooks_.List();
  if (!hooks.ok()) return ToGrpcStatus(hooks.status());
  for (const store::WebhookRecord& hook : *hooks) {
    ToProto(hook, response->add_webhooks());
  }
  return grpc::Status::OK;
}

grpc::Status AdminService::DeleteWebhook(
    grpc::ServerContext* context, const v1::DeleteWebhookRequest* request,
    v1::Webhook* response) {
  Caller caller;
  if (grpc::Status s = calls_.Admit(*context, &caller); !s.ok()) return s;
  if (absl::Status s = ValidateWebhookId(request->id()); !s.ok()) {
    return ToGrpcStatus(s);
  }
  absl::StatusOr<store::WebhookRecord> deleted =
      webhooks_.Delete(request->id());
  if (!deleted.ok()) return ToGrpcStatus(deleted.status());
  spdlog::info("webhook {} to {} deleted by {}", deleted->id,
               notify::UrlOrigin(deleted->url), caller.principal.name);
  ToProto(*deleted, response);
  return grpc::Status::OK;
}

grpc::Status AdminService::ListWebhookDeliveries(
    grpc::ServerContext* context,
    const v1::ListWebhookDeliveriesRequest* request,
    v1::ListWebhookDeliveriesResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (absl::Status s = ValidateWebhookId(request->webhook_id()); !s.ok()) {
    return ToGrpcStatus(s);
  }
  absl::StatusOr<IdPage> page = ParseIdPage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  if (absl::StatusOr<store::WebhookRecord> hook =
          webhooks_.Get(request->webhook_id());
      !hook.ok()) {
    return ToGrpcStatus(hook.status());
  }
  absl::StatusOr<std::vector<store::DeliveryAttempt>> rows =
      webhooks_.Attempts(request->webhook_id(), page->after, page->size + 1);
  if (!rows.ok()) return ToGrpcStatus(rows.status());
  response->set_next_page_token(FinishIdPage(
      *page, *rows, [](const store::DeliveryAttempt& row) { return row.id; }));
  for (const store::DeliveryAttempt& row : *rows) {
    v1::WebhookDelivery* out = response->add_deliveries();
    out->set_id(row.id);
    out->set_event_id(row.event_id);
    out->set_event_type(row.type);
    out->set_attempt(row.attempt);
    *out->mutable_time() = TimeUtil::MillisecondsToTimestamp(row.time_ms);
    out->set_duration_ms(row.duration_ms);
    out->set_http_status(row.http_status);
    out->set_error(row.error);
    out->set_event_state(store::OutboxStateName(row.event_state));
  }
  return grpc::Status::OK;
}

}  // namespace hdrstereo::rpc
