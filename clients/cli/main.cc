// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo: the operator's command-line client for hdrstereod.
#include <iostream>

#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "clients/cli/client.h"
#include "clients/cli/commands.h"
#include "hdrstereo_version.h"

namespace hdrstereo::cli {

Client::Client(const GlobalOptions& options)
    : options_(options),
      channel_(grpc::CreateChannel(options.server,
                                   grpc::InsecureChannelCredentials())) {}

std::unique_ptr<grpc::ClientContext> Client::NewContext() const {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(
      absl::ToChronoTime(absl::Now() + absl::Seconds(options_.timeout_s)));
  return context;
}

int Client::Fail(const grpc::Status& status) const {
  switch (status.error_code()) {
    case grpc::StatusCode::UNAVAILABLE:
      std::cerr << "hdrstereo: cannot reach hdrstereod at " << options_.server
                << ": " << status.error_message() << "\n";
      return kExitUnreachable;
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      // A device that timed out (a stalled stage) comes back from the daemon
      // with this code and the daemon's message; only gRPC's own "Deadline
      // Exceeded" means that the daemon did not answer within --timeout.
      if (status.error_message() != "Deadline Exceeded") {
        std::cerr << "hdrstereo: " << status.error_message() << "\n";
        return kExitError;
      }
      std::cerr << "hdrstereo: hdrstereod at " << options_.server
                << " did not answer within " << options_.timeout_s << " s\n";
      return kExitUnreachable;
    case grpc::StatusCode::INVALID_ARGUMENT:
      std::cerr << "hdrstereo: " << status.error_message() << "\n";
      return kExitUsage;
    case grpc::StatusCode::NOT_FOUND:
      std::cerr << "hdrstereo: " << status.error_message() << "\n";
      return kExitNotFound;
    default:
      std::cerr << "hdrstereo: " << status.error_message() << "\n";
      return kExitError;
  }
}

}  // namespace hdrstereo::cli

int main(int argc, char** argv) {
  using namespace hdrstereo::cli;
  GlobalOptions options;
  if (const char* env = std::getenv("HDRSTEREO_SERVER"); env && *env) {
    options.server = env;
  }
  CLI::App app{"hdrstereo: operate an hdrstereod acquisition daemon",
               "hdrstereo"};
  app.set_version_flag("--version", HDRSTEREO_VERSION);
  app.require_subcommand(1);
  app.fallthrough();
  app.footer(
      "Exit codes: 0 ok, 1 the server refused or failed, 2 bad usage or "
      "argument, 3 server unreachable, 4 not found.\n"
      "The server defaults to $HDRSTEREO_SERVER or localhost:50051.");
  app.add_option("--server", options.server, "hdrstereod address (HOST:PORT)")
      ->capture_default_str();
  app.add_flag("--json", options.json, "Print results as JSON");
  app.add_option("--timeout", options.timeout_s, "Seconds to wait per call")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();

  int exit_code = kExitOk;
  AddServerCommands(app, options, &exit_code);
  AddSessionCommands(app, options, &exit_code);
  AddHardwareCommands(app, options, &exit_code);
  AddJobCommands(app, options, &exit_code);
  AddProcessingCommands(app, options, &exit_code);
  AddScheduleCommands(app, options, &exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int rc = app.exit(e);
    return rc == 0 ? kExitOk : kExitUsage;
  }
  return exit_code;
}
