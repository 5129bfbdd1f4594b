// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo admin key create|list|revoke`, `hdrstereo admin webhook
// create|list|delete|deliveries` and `hdrstereo audit`.
#include <google/protobuf/util/time_util.h>

#include <algorithm>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "clients/cli/commands.h"
#include "clients/cli/output.h"
#include "clients/cli/time_args.h"
#include "hdrstereo/v1/admin.grpc.pb.h"

namespace hdrstereo::cli {
namespace {

using google::protobuf::util::TimeUtil;

std::string RoleName(v1::Role role) {
  if (role == v1::ROLE_UNSPECIFIED) return "none";
  return absl::AsciiStrToLower(v1::Role_Name(role).substr(5));  // "ROLE_"
}

std::string TimeOrDash(const google::protobuf::Timestamp& time) {
  return time.seconds() == 0 && time.nanos() == 0 ? "-" : FormatTime(time);
}

std::string Dash(const std::string& text) { return text.empty() ? "-" : text; }

struct Args {
  std::string user;
  std::string role;
  std::string expires = "90d";
  std::string note;
  std::string id;
  bool all = false;
  std::string since;
  std::string until;
  std::string principal;
  std::string method;
  int limit = 50;
  std::string url;
  std::vector<std::string> events;
  int64_t webhook_id = 0;
};

int RunCreate(const Client& client, const Args& args) {
  absl::StatusOr<absl::Duration> ttl = ParseDurationArg(args.expires);
  if (!ttl.ok()) {
    std::cerr << "hdrstereo: --expires: " << ttl.status().message() << "\n";
    return kExitUsage;
  }
  v1::CreateApiKeyRequest request;
  request.set_user(args.user);
  request.set_role(args.role == "viewer"     ? v1::ROLE_VIEWER
                   : args.role == "operator" ? v1::ROLE_OPERATOR
                                             : v1::ROLE_ADMIN);
  request.set_ttl_s(absl::ToInt64Seconds(*ttl));
  request.set_note(args.note);
  v1::CreateApiKeyResponse response;
  grpc::Status status =
      v1::Admin::NewStub(client.channel())
          ->CreateApiKey(client.NewContext().get(), request, &response);
  return Finish(
      client, status, response, [](const v1::CreateApiKeyResponse& r) {
        std::cout << r.api_key() << "\n";
        std::cerr << "API key " << r.key().id() << " for " << r.key().user()
                  << " (" << RoleName(r.key().role()) << "), expires "
                  << FormatTime(r.key().expire_time())
                  << ".\nIt is shown only now: store it in a file only its "
                     "owner can read (chmod 600) and pass --api-key-file.\n";
      });
}

int RunList(const Client& client, const Args& args) {
  auto stub = v1::Admin::NewStub(client.channel());
  v1::ListApiKeysRequest request;
  request.set_user(args.user);
  request.set_include_revoked(args.all);
  v1::ListApiKeysResponse all;
  do {
    v1::ListApiKeysResponse page;
    grpc::Status status =
        stub->ListApiKeys(client.NewContext().get(), request, &page);
    if (!status.ok()) return client.Fail(status);
    all.mutable_keys()->MergeFrom(page.keys());
    request.mutable_page()->set_page_token(page.next_page_token());
  } while (!request.page().page_token().empty());
  return Finish(
      client, grpc::Status::OK, all, [](const v1::ListApiKeysResponse& r) {
        if (r.keys().empty()) {
          std::cout << "no API keys\n";
          return;
        }
        Table table({"ID", "USER", "ROLE", "EXPIRES", "LAST USED", "REVOKED",
                     "CREATED BY", "NOTE"});
        for (const v1::ApiKey& k : r.keys()) {
          table.AddRow({k.id(), k.user(), RoleName(k.role()),
                        FormatTime(k.expire_time()),
                        TimeOrDash(k.last_used_time()),
                        TimeOrDash(k.revoke_time()), k.created_by(), k.note()});
        }
        table.Print(std::cout);
      });
}

int RunRevoke(const Client& client, const Args& args) {
  v1::RevokeApiKeyRequest request;
  request.set_id(args.id);
  v1::ApiKey key;
  grpc::Status status =
      v1::Admin::NewStub(client.channel())
          ->RevokeApiKey(client.NewContext().get(), request, &key);
  return Finish(client, status, key, [](const v1::ApiKey& k) {
    std::cout << "revoked API key " << k.id() << " of " << k.user()
              << "; it fails from its next call on\n";
  });
}

std::string Join(const google::protobuf::RepeatedPtrField<std::string>& list) {
  std::string out;
  for (const std::string& item : list) {
    absl::StrAppend(&out, out.empty() ? "" : ",", item);
  }
  return out.empty() ? "all" : out;
}

int RunWebhookCreate(const Client& client, const Args& args) {
  v1::CreateWebhookRequest request;
  request.set_url(args.url);
  for (const std::string& event : args.events) request.add_events(event);
  request.set_note(args.note);
  v1::CreateWebhookResponse response;
  grpc::Status status =
      v1::Admin::NewStub(client.channel())
          ->CreateWebhook(client.NewContext().get(), request, &response);
  return Finish(
      client, status, response, [](const v1::CreateWebhookResponse& r) {
        std::cout << r.secret() << "\n";
        std::cerr << "webhook " << r.webhook().id() << " to "
                  << r.webhook().url() << " (events "
                  << Join(r.webhook().events())
                  << ").\nIts signing secret is shown only now: give it to "
                     "the receiver, which checks X-Hdrstereo-Signature "
                     "(docs/notifications.md).\n";
      });
}

int RunWebhookList(const Client& client) {
  v1::ListWebhooksResponse response;
  grpc::Status status =
      v1::Admin::NewStub(client.channel())
          ->ListWebhooks(client.NewContext().get(), v1::ListWebhooksRequest(),
                         &response);
  return Finish(
      client, status, response, [](const v1::ListWebhooksResponse& r) {
        if (r.webhooks().empty()) {
          std::cout << "no webhooks\n";
          return;
        }
        Table table({"ID", "URL", "EVENTS", "PENDING", "DELIVERED", "ABANDONED",
                     "LAST ATTEMPT", "LAST ERROR", "CREATED BY", "NOTE"});
        for (const v1::Webhook& h : r.webhooks()) {
          table.AddRow({absl::StrCat(h.id()), h.url(), Join(h.events()),
                        absl::StrCat(h.pending()), absl::StrCat(h.delivered()),
                        absl::StrCat(h.abandoned()),
                        TimeOrDash(h.last_attempt_time()), Dash(h.last_error()),
                        h.created_by(), h.note()});
        }
        table.Print(std::cout);
      });
}

int RunWebhookDelete(const Client& client, const Args& args) {
  v1::DeleteWebhookRequest request;
  request.set_id(args.webhook_id);
  v1::Webhook hook;
  grpc::Status status =
      v1::Admin::NewStub(client.channel())
          ->DeleteWebhook(client.NewContext().get(), request, &hook);
  return Finish(client, status, hook, [](const v1::Webhook& h) {
    std::cout << "deleted webhook " << h.id() << " to " << h.url() << " ("
              << h.pending() << " undelivered events dropped)\n";
  });
}

int RunWebhookDeliveries(const Client& client, const Args& args) {
  v1::ListWebhookDeliveriesRequest request;
  request.set_webhook_id(args.webhook_id);
  request.mutable_page()->set_page_size(std::min(args.limit, 1000));
  v1::ListWebhookDeliveriesResponse response;
  grpc::Status status = v1::Admin::NewStub(client.channel())
                            ->ListWebhookDeliveries(client.NewContext().get(),
                                                    request, &response);
  return Finish(
      client, status, response, [](const v1::ListWebhookDeliveriesResponse& r) {
        if (r.deliveries().empty()) {
          std::cout << "no delivery attempts\n";
          return;
        }
        Table table(
            {"TIME", "EVENT", "TYPE", "ATTEMPT", "HTTP", "MS", "ERROR", "NOW"});
        for (const v1::WebhookDelivery& d : r.deliveries()) {
          table.AddRow(
              {FormatTime(d.time()), d.event_id(), d.event_type(),
               absl::StrCat(d.attempt()),
               d.http_status() == 0 ? "-" : absl::StrCat(d.http_status()),
               absl::StrCat(d.duration_ms()), Dash(d.error()),
               d.event_state()});
        }
        table.Print(std::cout);
      });
}

int RunAudit(const Client& client, const Args& args) {
  v1::ListAuditLogRequest request;
  request.set_principal(args.principal);
  request.set_method(args.method);
  const absl::Time now = absl::Now();
  auto time_arg = [now](const std::string& text, const char* name,
                        google::protobuf::Timestamp* out) {
    absl::StatusOr<absl::Time> time =
        ParseTimeArg(text, now, absl::LocalTimeZone());
    if (!time.ok()) {
      std::cerr << "hdrstereo: " << name << ": " << time.status().message()
                << "\n";
      return false;
    }
    *out = TimeUtil::MillisecondsToTimestamp(absl::ToUnixMillis(*time));
    return true;
  };
  if (!args.since.empty() &&
      !time_arg(args.since, "--since", request.mutable_start_time())) {
    return kExitUsage;
  }
  if (!args.until.empty() &&
      !time_arg(args.until, "--until", request.mutable_end_time())) {
    return kExitUsage;
  }
  request.mutable_page()->set_page_size(std::min(args.limit, 1000));
  v1::ListAuditLogResponse response;
  grpc::Status status =
      v1::Admin::NewStub(client.channel())
          ->ListAuditLog(client.NewContext().get(), request, &response);
  return Finish(
      client, status, response, [](const v1::ListAuditLogResponse& r) {
        if (r.entries().empty()) {
          std::cout << "no audit entries\n";
          return;
        }
        Table table({"TIME", "PRINCIPAL", "ROLE", "AUTH", "TRANSPORT", "PEER",
                     "METHOD", "SUBJECT", "STATUS", "MESSAGE"});
        for (const v1::AuditEntry& e : r.entries()) {
          table.AddRow({FormatTime(e.time()), Dash(e.principal()),
                        RoleName(e.role()), Dash(e.auth_method()),
                        Dash(e.transport()), Dash(e.peer()), e.method(),
                        Dash(e.subject()),
                        absl::StatusCodeToString(
                            static_cast<absl::StatusCode>(e.status_code())),
                        e.message()});
        }
        table.Print(std::cout);
      });
}

}  // namespace

void AddAdminCommands(CLI::App& app, const GlobalOptions& options,
                      int* exit_code) {
  auto args = std::make_shared<Args>();
  CLI::App* admin =
      app.add_subcommand("admin", "API keys and webhooks (role admin)");
  admin->require_subcommand(1);
  CLI::App* key = admin->add_subcommand("key", "Create, list, revoke API keys");
  key->require_subcommand(1);

  CLI::App* create = key->add_subcommand(
      "create", "Create a key for a user; it is printed once");
  create->add_option("--user", args->user, "The key's user (in [auth.users])")
      ->required();
  create->add_option("--role", args->role, "At most the user's role")
      ->check(CLI::IsMember({"viewer", "operator", "admin"}))
      ->required();
  create->add_option("--expires", args->expires, "Lifetime, e.g. 30d, 12h")
      ->capture_default_str();
  create->add_option("--note", args->note, "What it is for");
  create->callback([&options, exit_code, args] {
    *exit_code = RunCreate(Client(options), *args);
  });

  CLI::App* list = key->add_subcommand("list", "List keys (never secrets)");
  list->add_option("--user", args->user, "Only this user's keys");
  list->add_flag("--all", args->all, "Also revoked and expired keys");
  list->callback([&options, exit_code, args] {
    *exit_code = RunList(Client(options), *args);
  });

  CLI::App* revoke =
      key->add_subcommand("revoke", "Revoke a key (from its next call on)");
  revoke->add_option("ID", args->id, "Key id, as `key list` shows")->required();
  revoke->callback([&options, exit_code, args] {
    *exit_code = RunRevoke(Client(options), *args);
  });

  CLI::App* webhook = admin->add_subcommand(
      "webhook", "Create, list, delete webhooks; their delivery attempts");
  webhook->require_subcommand(1);
  CLI::App* hook_create = webhook->add_subcommand(
      "create", "Send events to a URL; prints its signing secret once");
  hook_create->add_option("--url", args->url, "http:// or https:// URL")
      ->required();
  hook_create
      ->add_option("--events", args->events,
                   "Event types, comma-separated (job.failed, job.*, "
                   "schedule_run.*, ...) [default: all]")
      ->delimiter(',');
  hook_create->add_option("--note", args->note, "What it is for");
  hook_create->callback([&options, exit_code, args] {
    *exit_code = RunWebhookCreate(Client(options), *args);
  });
  CLI::App* hook_list =
      webhook->add_subcommand("list", "Webhooks and how their delivery goes");
  hook_list->callback(
      [&options, exit_code] { *exit_code = RunWebhookList(Client(options)); });
  CLI::App* hook_delete = webhook->add_subcommand(
      "delete", "Delete a webhook and its undelivered events");
  hook_delete->add_option("ID", args->webhook_id, "Webhook id, as list shows")
      ->required();
  hook_delete->callback([&options, exit_code, args] {
    *exit_code = RunWebhookDelete(Client(options), *args);
  });
  CLI::App* hook_deliveries = webhook->add_subcommand(
      "deliveries", "A webhook's delivery attempts, newest first");
  hook_deliveries->add_option("ID", args->webhook_id, "Webhook id")->required();
  hook_deliveries
      ->add_option("--limit", args->limit, "At most this many attempts")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  hook_deliveries->callback([&options, exit_code, args] {
    *exit_code = RunWebhookDeliveries(Client(options), *args);
  });

  CLI::App* audit = app.add_subcommand(
      "audit", "Audited calls, newest first: changes and refusals (admin)");
  audit->add_option("--since", args->since,
                    "From this time (2026-11-23 14:05) or this long ago (2h)");
  audit->add_option("--until", args->until, "Up to this time");
  audit->add_option("--principal", args->principal, "Only this principal");
  audit->add_option("--method", args->method,
                    "Only methods containing this, e.g. SubmitCapture");
  audit->add_option("--limit", args->limit, "At most this many entries")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  audit->callback([&options, exit_code, args] {
    *exit_code = RunAudit(Client(options), *args);
  });
}

}  // namespace hdrstereo::cli
