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
      channel_(grpc::CreateChannel(options.connection.server,
                                   CredentialsFor(options.connection))) {}

std::unique_ptr<grpc::ClientContext> Client::NewContext() const {
  auto context = std::make_unique<grpc::ClientContext>();
  deadline_ = absl::Now() + absl::Seconds(options_.timeout_s);
  context->set_deadline(absl::ToChronoTime(deadline_));
  return context;
}

std::unique_ptr<grpc::ClientContext> Client::NewStreamContext() const {
  deadline_ = absl::InfiniteFuture();
  return std::make_unique<grpc::ClientContext>();
}

int Client::Fail(const grpc::Status& status) const {
  const Connection& connection = options_.connection;
  switch (status.error_code()) {
    case grpc::StatusCode::UNAVAILABLE: {
      std::cerr << "hdrstereo: cannot reach hdrstereod at " << connection.server
                << ": " << status.error_message();
      // Transport mismatches and rejected certificates look alike from here;
      // name what to check.
      if (!connection.tls) {
        std::cerr << " (if hdrstereod serves TLS there, connect with --tls-ca "
                     "or a --profile)";
      } else {
        std::cerr << " (over TLS: is it hdrstereod's TLS port, does --tls-ca "
                     "sign its certificate, and is your certificate signed by "
                     "the lab CA, valid now and not revoked?)";
      }
      std::cerr << "\n";
      return kExitUnreachable;
    }
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      // A device that timed out (a stalled stage) comes back from the daemon
      // with this code before the call's own deadline has passed.
      if (absl::Now() < deadline_) {
        std::cerr << "hdrstereo: " << status.error_message() << "\n";
        return kExitError;
      }
      std::cerr << "hdrstereo: hdrstereod at " << connection.server
                << " did not answer within " << options_.timeout_s << " s\n";
      return kExitUnreachable;
    case grpc::StatusCode::INVALID_ARGUMENT:
      std::cerr << "hdrstereo: " << status.error_message() << "\n";
      return kExitUsage;
    case grpc::StatusCode::NOT_FOUND:
      std::cerr << "hdrstereo: " << status.error_message() << "\n";
      return kExitNotFound;
    case grpc::StatusCode::UNAUTHENTICATED:
      std::cerr << "hdrstereo: not authenticated by hdrstereod at "
                << connection.server << ": " << status.error_message() << "\n";
      return kExitUnauthenticated;
    case grpc::StatusCode::PERMISSION_DENIED:
      std::cerr << "hdrstereo: permission denied: " << status.error_message()
                << "\n";
      return kExitPermissionDenied;
    default:
      std::cerr << "hdrstereo: " << status.error_message() << "\n";
      return kExitError;
  }
}

}  // namespace hdrstereo::cli

int main(int argc, char** argv) {
  using namespace hdrstereo::cli;
  GlobalOptions options;
  CLI::App app{"hdrstereo: operate an hdrstereod acquisition daemon",
               "hdrstereo"};
  app.set_version_flag("--version", HDRSTEREO_VERSION);
  app.require_subcommand(1);
  app.fallthrough();
  app.footer(
      "Exit codes: 0 ok, 1 the server refused or failed, 2 bad usage or "
      "argument, 3 server unreachable, 4 not found, 5 not authenticated, 6 "
      "permission denied.\n"
      "Each connection setting comes from the option, else the environment "
      "($HDRSTEREO_SERVER, $HDRSTEREO_PROFILE, $HDRSTEREO_TLS_CA, "
      "$HDRSTEREO_TLS_CERT, $HDRSTEREO_TLS_KEY, $HDRSTEREO_API_KEY_FILE), "
      "else the profile in ~/.config/hdrstereo/client.toml "
      "($HDRSTEREO_CLIENT_CONFIG), else the default: localhost:50051 "
      "without TLS.");
  ConnectionOptions& flags = options.flags;
  app.add_option("--server", flags.server,
                 "hdrstereod address (HOST:PORT or unix:PATH)");
  app.add_option("--profile", flags.profile,
                 "Connection profile from client.toml");
  app.add_option("--tls-ca", flags.tls_ca,
                 "The lab CA's certificate (PEM): connect with TLS");
  app.add_option("--tls-cert", flags.tls_cert, "Client certificate (PEM)");
  app.add_option("--tls-key", flags.tls_key,
                 "Its private key (PEM, mode 0600)");
  app.add_option("--api-key-file", flags.api_key_file,
                 "File holding an API key (mode 0600), instead of a "
                 "certificate");
  // Resolved once, before any command's callback runs.
  app.parse_complete_callback([&options] {
    absl::StatusOr<Connection> connection = ResolveConnection(options.flags);
    if (!connection.ok()) {
      std::cerr << "hdrstereo: " << connection.status().message() << "\n";
      throw CLI::RuntimeError(kExitUsage);
    }
    options.connection = *std::move(connection);
  });
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
  AddAdminCommands(app, options, &exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int rc = app.exit(e);
    return rc == 0 ? kExitOk : kExitUsage;
  }
  return exit_code;
}
