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
// overrides the path); the Python client reads the same file:
//
//   default_profile = "lab"            # optional
//   [profile.lab]
//   server = "labpc.example.org:50051"
//   tls_ca = "lab-ca.pem"              # relative paths: to this file's folder
//   tls_cert = "alice.pem"             # client certificate (PEM)
//   tls_key = "alice.key"              # its key (PEM, mode 0600)
//   api_key_file = "notebook.key"      # instead of cert and key (mode 0600)
//
// The profile is --profile, else $HDRSTEREO_PROFILE, else default_profile.
// Unknown keys and sections are refused by name. TLS is used when a CA is
// given; a certificate, key or API key without one is refused (they are
// never sent in the clear), and so is a private-key or API-key file that
// group or others can read.
#ifndef HDRSTEREO_CLIENTS_CLI_CONNECTION_H_
#define HDRSTEREO_CLIENTS_CLI_CONNECTION_H_

#include <grpcpp/security/credentials.h>

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::cli {

inline constexpr char kDefaultServer[] = "localhost:50051";

// The connection settings of one profile, paths as written in the file.
struct Profile {
  std::string server;
  std::string tls_ca;
  std::string tls_cert;
  std::string tls_key;
  std::string api_key_file;
};

struct ProfileFile {
  std::string default_profile;
  std::map<std::string, Profile> profiles;
};

// Parses the text of a client.toml; INVALID_ARGUMENT naming `path`, the
// line and the offending key or section.
absl::StatusOr<ProfileFile> ParseProfileFile(const std::string& path,
                                             absl::string_view text);

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
