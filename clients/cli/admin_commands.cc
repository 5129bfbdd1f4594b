// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo admin key create|list|revoke` and `hdrstereo audit`.
#include <google/protobuf/util/time_util.h>

#include <algorithm>
#include <iostream>
#include <memory>

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
        Table table({"TIME", "PRINCIPAL", "ROLE", "AUTH", "PEER", "METHOD",
                     "SUBJECT", "STATUS", "MESSAGE"});
        for (const v1::AuditEntry& e : r.entries()) {
          table.AddRow({FormatTime(e.time()), Dash(e.principal()),
                        RoleName(e.role()), Dash(e.auth_method()),
                        Dash(e.peer()), e.method(), Dash(e.subject()),
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
  CLI::App* admin = app.add_subcommand("admin", "API keys (role admin)");
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
