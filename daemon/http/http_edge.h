// SPDX-License-Identifier: GPL-3.0-or-later
//
// The daemon's HTTP edge (Boost.Beast): the whole hdrstereo.v1 API in the
// Connect protocol's shape for browsers, curl and MATLAB, the artifacts and
// frames of sessions as plain downloads, and browser sign-in. It decides
// nothing about roles: every call goes to the services through the
// in-process channel stamped with the caller it authenticated, and the
// guard every path runs decides, audits and applies the rig lock.
//
// Routes:
//   GET|HEAD /  and  /<file>                 the operator's console
//                                            (console_files.h): no
//                                            credentials, ETag, no-cache
//   POST /hdrstereo.v1.<Service>/<Method>    Connect unary or server stream
//                                            (or, for streams with Accept:
//                                            text/event-stream, SSE)
//   POST /auth/sign-in  {"apiKey": "hs_..."} a session cookie
//   POST /auth/sign-out
//   GET|HEAD /auth/session                   {"signedIn": true|false}: is
//                                            the session cookie (or client
//                                            certificate) good
//   GET|HEAD /files/sessions/<session>/artifacts/<id>   Range, ETag (sha256)
//   GET|HEAD /files/sessions/<session>/frames/<id>
//
// Who calls: every request but the console's files and /auth/session needs
// credentials, also on loopback (any page a browser shows can send requests
// there): a session cookie, Authorization: Bearer <API key>, or (TLS) a
// client certificate of the lab CA. Host must
// be a served name; mutations need a JSON or Connect content type (never a
// form's) and an Origin that is the edge's own whenever they carry one, and
// always with a session cookie.
#ifndef HDRSTEREO_DAEMON_HTTP_HTTP_EDGE_H_
#define HDRSTEREO_DAEMON_HTTP_HTTP_EDGE_H_

#include <grpcpp/channel.h>

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "daemon/http/browser_sessions.h"
#include "daemon/http/console_files.h"
#include "daemon/http/sign_in_throttle.h"
#include "daemon/rpc/api_keys.h"
#include "daemon/rpc/audit_log.h"
#include "daemon/rpc/authenticator.h"
#include "daemon/rpc/edge_stamp.h"
#include "daemon/rpc/server_credentials.h"

namespace hdrstereo::http {

struct HttpEdgeOptions {
  // HOST:PORT each; loopback may be plain HTTP, anything else needs `tls`.
  std::vector<std::string> listen;
  // Names the edge answers to besides those of its listen addresses (and
  // localhost / 127.0.0.1 / [::1] for loopback ones): the Host header must
  // name one.
  std::vector<std::string> hosts;
  // The operator's console: the directory of its built files, read once at
  // Start. One that does not exist is served as "not installed" (a 404 at
  // /) unless `web_root_named` (--web-root was given): then Start fails.
  std::filesystem::path web_root;
  bool web_root_named = false;
  ConsoleLimits console_limits;
  BrowserSessionOptions sessions;
  SignInThrottleOptions sign_in;
  // Connections at once; beyond it a connection gets 503 and is closed.
  size_t max_connections = 256;
  size_t max_body_bytes = size_t{4} << 20;  // gRPC's default message limit
  size_t max_header_bytes = size_t{16} << 10;
  // From a connection's start (or the end of the previous response) to the
  // end of the request's headers; and to the end of its body.
  absl::Duration header_timeout = absl::Seconds(10);
  absl::Duration body_timeout = absl::Seconds(30);
  // A kept-alive connection with no new request is closed after this.
  absl::Duration idle_timeout = absl::Seconds(60);
  // A response (or a stream's message) the client does not take within
  // this closes the connection.
  absl::Duration write_timeout = absl::Seconds(30);
  // Unary calls without Connect-Timeout-Ms.
  absl::Duration unary_timeout = absl::Minutes(5);
  int threads = 2;
};

// What the edge uses of the daemon.
struct HttpEdgeServices {
  std::shared_ptr<grpc::Channel> channel;  // the server's in-process one
  const rpc::EdgeStamp* stamp = nullptr;
  rpc::ApiKeyStore* keys = nullptr;
  rpc::Authenticator* authenticator = nullptr;
  rpc::AuditLog* audit = nullptr;
};

class HttpEdge {
 public:
  // Loads the console, binds every address (port 0: a free one) and starts
  // serving; UNAVAILABLE naming an address that cannot be bound,
  // INVALID_ARGUMENT for one that is not loopback while `tls` is null, the
  // errors of ConsoleFiles::Load, and NOT_FOUND for a named web root that
  // does not exist.
  static absl::StatusOr<std::unique_ptr<HttpEdge>> Start(
      const HttpEdgeOptions& options, const rpc::TlsMaterial* tls,
      HttpEdgeServices services);
  ~HttpEdge();

  // The addresses bound, in `listen` order, with their ports.
  const std::vector<std::string>& addresses() const;
  // Stops accepting, closes every connection (cancelling their calls) and
  // joins the threads. Idempotent.
  void Stop();

  class Impl;

 private:
  explicit HttpEdge(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace hdrstereo::http

#endif  // HDRSTEREO_DAEMON_HTTP_HTTP_EDGE_H_
