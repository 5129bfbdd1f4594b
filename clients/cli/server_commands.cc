// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo status`: is the daemon serving, and which versions does it run.
// `hdrstereo whoami`: who the daemon takes the caller to be.
#include <iostream>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "clients/cli/commands.h"
#include "clients/cli/output.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "hdrstereo/v1/server.grpc.pb.h"

namespace hdrstereo::cli {
namespace {

std::string ServingStatusName(
    grpc::health::v1::HealthCheckResponse::ServingStatus s) {
  return grpc::health::v1::HealthCheckResponse::ServingStatus_Name(s);
}

int RunStatus(const Client& client) {
  grpc::health::v1::HealthCheckResponse health;
  grpc::Status status = grpc::health::v1::Health::NewStub(client.channel())
                            ->Check(client.NewContext().get(), {}, &health);
  if (!status.ok()) return client.Fail(status);

  v1::ServerInfo info;
  status = v1::Server::NewStub(client.channel())
               ->GetInfo(client.NewContext().get(), {}, &info);
  if (!status.ok()) return client.Fail(status);

  if (client.options().json) {
    PrintJson(std::cout, info);
  } else {
    PrintFields(
        std::cout,
        {
            {"server", client.options().connection.server},
            {"health", ServingStatusName(health.status())},
            {"version", info.version()},
            {"libraries",
             absl::StrFormat("gRPC %s, OpenCV %s, SQLite %s",
                             info.grpc_version(), info.opencv_version(),
                             info.sqlite_version())},
            {"schema", absl::StrCat(info.schema_version())},
            {"data root", info.data_root()},
            {"disk", absl::StrFormat("%.1f MB free, %.1f MB promised to "
                                     "unfinished captures",
                                     info.data_root_free_bytes() / 1e6,
                                     info.pending_capture_bytes() / 1e6)},
            {"hardware", info.hardware_mode()},
            {"uptime", absl::StrCat(info.uptime_s(), " s")},
        });
  }
  return health.status() == grpc::health::v1::HealthCheckResponse::SERVING
             ? kExitOk
             : kExitError;
}

int RunWhoAmI(const Client& client) {
  v1::Identity identity;
  grpc::Status status = v1::Server::NewStub(client.channel())
                            ->WhoAmI(client.NewContext().get(), {}, &identity);
  return Finish(client, status, identity, [&client](const v1::Identity& i) {
    std::vector<std::pair<std::string, std::string>> fields = {
        {"principal", i.principal()},
        {"role",
         i.role() == v1::ROLE_UNSPECIFIED
             ? "none (every call but whoami is refused)"
             : absl::AsciiStrToLower(v1::Role_Name(i.role()).substr(5))},
        {"auth", i.auth_method()},
        {"server", client.options().connection.server},
        {"seen from", i.peer()}};
    if (i.has_key_expire_time()) {
      fields.push_back({"key expires", FormatTime(i.key_expire_time())});
    }
    if (!client.options().connection.profile.empty()) {
      fields.push_back({"profile", client.options().connection.profile});
    }
    PrintFields(std::cout, fields);
  });
}

}  // namespace

void AddServerCommands(CLI::App& app, const GlobalOptions& options,
                       int* exit_code) {
  app.add_subcommand("status", "Show whether hdrstereod serves, and versions")
      ->callback(
          [&options, exit_code] { *exit_code = RunStatus(Client(options)); });
  app.add_subcommand("whoami",
                     "Show the principal, role and authentication the daemon "
                     "sees for you")
      ->callback(
          [&options, exit_code] { *exit_code = RunWhoAmI(Client(options)); });
}

}  // namespace hdrstereo::cli
