// SPDX-License-Identifier: GPL-3.0-or-later
//
// An HTTP client for tests of the daemon's HTTP edge: libcurl, the
// library made for it, so that requests are what a real client sends. With
// the Connect protocol's pieces a test needs (a unary JSON call, a server
// stream's enveloped messages) written out here from the protocol's
// documentation, independently of the daemon's code.
#ifndef HDRSTEREO_TESTS_SUPPORT_HTTP_CLIENT_H_
#define HDRSTEREO_TESTS_SUPPORT_HTTP_CLIENT_H_

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/time/time.h"
#include "nlohmann/json.hpp"

namespace hdrstereo::testing {

struct HttpRequest {
  std::string method = "POST";
  std::string url;
  std::vector<std::string> headers;  // "Name: value"
  std::string body;
  // TLS: the CA to trust, and a client certificate (empty: none).
  std::filesystem::path ca;
  std::filesystem::path cert;
  std::filesystem::path key;
  absl::Duration timeout = absl::Seconds(30);
  // When set, the body is handed over as it arrives (not kept in the
  // response); returning false ends the transfer.
  std::function<bool(const std::string& bytes)> on_body;
  // A small socket receive buffer (0: the system's), for a client that
  // reads slowly and must not have the kernel hold many messages for it.
  int receive_buffer_bytes = 0;
  // Send the URL's path as written: curl otherwise resolves "/../" and
  // "/./" itself, as browsers do, and a test of such paths never sends one.
  bool path_as_is = false;
};

struct HttpResponse {
  long status = 0;  // 0 when no response came (curl_error says why)
  std::string curl_error;
  std::multimap<std::string, std::string> headers;  // names lower-case
  std::string body;

  // The first value of header `name` (lower-case), "" when absent.
  std::string Header(const std::string& name) const;
  // The body as JSON (discarded when it is not).
  nlohmann::json Json() const;
};

HttpResponse Fetch(const HttpRequest& request);

// One message of a Connect stream.
struct StreamMessage {
  bool end = false;     // the end-of-stream message
  std::string payload;  // JSON or binary, as the content type says
};
// The first enveloped message of `buffered`, removed from it; nullopt while
// it holds less than a whole envelope (a stream read as it arrives).
std::optional<StreamMessage> TakeEnvelope(std::string& buffered);
// The enveloped messages of a Connect stream's body (a test failure for a
// malformed body).
std::vector<StreamMessage> ParseEnvelopes(const std::string& body);
// One message enveloped (flags 0).
std::string EnvelopeOf(const std::string& payload);

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_HTTP_CLIENT_H_
