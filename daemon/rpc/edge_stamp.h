// SPDX-License-Identifier: GPL-3.0-or-later
//
// The identity the HTTP edge stamps on the calls it forwards to the
// services through the server's in-process channel. In-process calls run no
// AuthMetadataProcessor and carry no TLS auth context, so the guard takes
// their caller from the stamp alone: the edge has authenticated the HTTP
// request (cookie session, API key or client certificate) and names the
// principal, its role, how it signed in and its peer address; the stamp, an
// HMAC-SHA256 of that caller field under a per-boot secret, compared in
// constant time, proves the edge wrote it (a stamp seen elsewhere vouches for
// its own caller only). A call arriving over the network with the stamp's
// metadata is refused (CallGuard).
#ifndef HDRSTEREO_DAEMON_RPC_EDGE_STAMP_H_
#define HDRSTEREO_DAEMON_RPC_EDGE_STAMP_H_

#include <grpcpp/client_context.h>
#include <grpcpp/support/string_ref.h>

#include <map>
#include <string>

#include "absl/status/statusor.h"
#include "daemon/rpc/authenticator.h"

namespace hdrstereo::rpc {

// Metadata keys of the stamp: the secret, and the caller it vouches for.
inline constexpr char kEdgeStampKey[] = "x-hdrstereo-edge-stamp";
inline constexpr char kEdgeCallerKey[] = "x-hdrstereo-edge-caller";

// Who called through the HTTP edge.
struct EdgeCaller {
  Principal principal;  // name, role, auth_method ("key:<id>", "cert", ...)
  std::string peer;     // the HTTP client's address, "ipv4:10.0.0.7:51234"
};

class EdgeStamp {
 public:
  // A fresh per-boot secret: 32 bytes from OpenSSL's RAND_bytes.
  static absl::StatusOr<EdgeStamp> Create();

  // Adds the stamp and `caller` to the metadata of a call the edge makes.
  void Apply(const EdgeCaller& caller, grpc::ClientContext& context) const;

  // The caller an in-process call's metadata names: UNAUTHENTICATED when
  // the stamp is missing or not this boot's for this caller field
  // (constant-time comparison), when either key is given twice, or the
  // caller field is malformed: more than 1024 bytes, a name that
  // ValidatePrincipalName refuses, an unknown role, an auth_method (1-64
  // bytes) or peer (1-256 bytes) that is not printable ASCII without spaces.
  // No message holds the secret or the stamp.
  absl::StatusOr<EdgeCaller> Verify(
      const std::multimap<grpc::string_ref, grpc::string_ref>& metadata) const;

 private:
  explicit EdgeStamp(std::string secret) : secret_(std::move(secret)) {}

  std::string secret_;  // 32 random bytes
};

// True when `metadata` carries either stamp key (a network call must not).
bool HasEdgeStamp(
    const std::multimap<grpc::string_ref, grpc::string_ref>& metadata);

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_EDGE_STAMP_H_
