// SPDX-License-Identifier: GPL-3.0-or-later
//
// The credentials of each listening address: TLS for any address that is not
// local (the daemon's certificate; client certificates requested and, when
// presented, verified against the lab CA and its revocation lists), gRPC's
// local credentials for loopback and unix sockets. CallGuard is installed on
// every one of them, so every call on every port passes it.
#ifndef HDRSTEREO_DAEMON_RPC_SERVER_CREDENTIALS_H_
#define HDRSTEREO_DAEMON_RPC_SERVER_CREDENTIALS_H_

#include <grpcpp/security/auth_metadata_processor.h>
#include <grpcpp/security/server_credentials.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "daemon/config.h"

namespace hdrstereo::rpc {

// The TLS files read and checked: INVALID_ARGUMENT naming the file when one
// is missing or unreadable, is not PEM of the right kind, when the key does
// not match the certificate, the certificate has expired, or the key is
// readable by others.
struct TlsMaterial {
  std::string cert_chain;
  std::string private_key;
  std::string client_ca;
  std::string crl_dir;
};
absl::StatusOr<TlsMaterial> LoadTlsMaterial(const daemon::TlsConfig& tls);

// Credentials for `address` (TLS unless daemon::IsLocalAddress), with
// `guard` (not null) as their metadata processor: what the daemon listens
// with.
std::shared_ptr<grpc::ServerCredentials> ServerCredentialsFor(
    const std::string& address, const TlsMaterial* tls,
    std::shared_ptr<grpc::AuthMetadataProcessor> guard);

// The TLS part alone, without a processor (for benches that measure what
// the processor adds).
std::shared_ptr<grpc::ServerCredentials> TlsCredentials(const TlsMaterial& tls);

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_SERVER_CREDENTIALS_H_
