// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo status`: is the daemon serving, and which versions does it run.
#include <iostream>

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
    PrintFields(std::cout,
                {
                    {"server", client.options().server},
                    {"health", ServingStatusName(health.status())},
                    {"version", info.version()},
                    {"libraries",
                     absl::StrFormat("gRPC %s, OpenCV %s, SQLite %s",
                                     info.grpc_version(), info.opencv_version(),
                                     info.sqlite_version())},
                    {"schema", absl::StrCat(info.schema_version())},
                    {"data root", info.data_root()},
                    {"hardware", info.hardware_mode()},
                    {"uptime", absl::StrCat(info.uptime_s(), " s")},
                });
  }
  return health.status() == grpc::health::v1::HealthCheckResponse::SERVING
             ? kExitOk
             : kExitError;
}

}  // namespace

void AddServerCommands(CLI::App& app, const GlobalOptions& options,
                       int* exit_code) {
  app.add_subcommand("status", "Show whether hdrstereod serves, and versions")
      ->callback(
          [&options, exit_code] { *exit_code = RunStatus(Client(options)); });
}

}  // namespace hdrstereo::cli
