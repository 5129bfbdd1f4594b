// SPDX-License-Identifier: GPL-3.0-or-later
//
// Where and how the CLI connects: the daemon's address and, for a remote
// daemon, TLS (the lab CA, a client certificate and key) or an API key.
// Each setting comes from, in this order: the command line, the
// environment (HDRSTEREO_SERVER, HDRSTEREO_TLS_CA, HDRSTEREO_TLS_CERT,
// HDRSTEREO_TLS_KEY, HDRSTEREO_API_KEY_FILE), the selected profile, the
// built-in default (localhost:50051, no TLS).
//
// Profiles live in ~/.config/hdrstereo/client.toml ($HDRSTEREO_CLIENT_CONFIG
// overrides the path; its format: profile_file.h). The profile is
// --profile, else $HDRSTEREO_PROFILE, else default_profile. TLS is used when a
// CA is given; a certificate, key or API key without one is refused (they are
// never sent in the clear), and so is a private-key or API-key file that
// group or others can read.
#ifndef HDRSTEREO_CLIENTS_CLI_CONNECTION_H_
#define HDRSTEREO_CLIENTS_CLI_CONNECTION_H_

#include <grpcpp/security/credentials.h>

#include <functional>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "clients/cli/profile_file.h"

namespace hdrstereo::cli {

inline constexpr char kDefaultServer[] = "localhost:50051";

// Settings as given on the command line; empty = not given.
struct ConnectionOptions {
  std::string server;
  std::string profile;
  std::string tls_ca;
  std::string tls_cert;
  std::string tls_key;
  std::string api_key_file;
};

// The resolved settings, files read.
struct Connection {
  std::string server = kDefaultServer;
  std::string profile;  // the profile used; "" = none
  bool tls = false;
  std::string ca_pem;
  std::string cert_pem;
  std::string key_pem;
  std::string api_key;  // hs_<id>_<secret>; "" = none
};

// `getenv` is injectable for tests. INVALID_ARGUMENT with a message that
// says what to change (which chmod, which option) for bad settings.
absl::StatusOr<Connection> ResolveConnection(
    const ConnectionOptions& flags,
    const std::function<const char*(const char*)>& getenv = ::getenv);

// TLS credentials (with the API key as per-call "authorization: Bearer",
// which gRPC sends over TLS only), or plaintext for a local daemon.
std::shared_ptr<grpc::ChannelCredentials> CredentialsFor(
    const Connection& connection);

}  // namespace hdrstereo::cli

#endif  // HDRSTEREO_CLIENTS_CLI_CONNECTION_H_
