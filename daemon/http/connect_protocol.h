// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Connect protocol's wire shapes (connectrpc.com/docs/protocol), as the
// HTTP edge speaks them: the code names and HTTP statuses of errors, the
// error body, the content types of unary and streaming calls, the 5-byte
// envelope of a streamed message, and Connect-Timeout-Ms. Pure functions on
// received bytes, so that a fuzz target runs them alone.
#ifndef HDRSTEREO_DAEMON_HTTP_CONNECT_PROTOCOL_H_
#define HDRSTEREO_DAEMON_HTTP_CONNECT_PROTOCOL_H_

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

namespace hdrstereo::http {

// "permission_denied" for absl::StatusCode::kPermissionDenied (Connect
// spells kCancelled "canceled").
absl::string_view ConnectCodeName(absl::StatusCode code);
// The HTTP status of a unary call that failed with `code`.
int HttpStatusOf(absl::StatusCode code);
// The error body: {"code": "...", "message": "..."} with the message
// unchanged (JSON-escaped); an OK status is "{}".
std::string ErrorJson(const absl::Status& status);

// How a request's body and the response are encoded.
enum class Codec { kJson, kProto };
struct ContentType {
  Codec codec = Codec::kJson;
  bool streaming = false;  // application/connect+json, connect+proto
};
// The Content-Type of an RPC request: application/json, application/proto,
// application/connect+json or application/connect+proto, parameters such
// as "; charset=utf-8" allowed (JSON only). nullopt for anything else, which
// includes every type an HTML form can send (urlencoded, multipart,
// text/plain): a cross-site page cannot make such a request without a CORS
// preflight, which the edge never answers.
std::optional<ContentType> ParseContentType(absl::string_view header);
// The Content-Type to answer with.
std::string ContentTypeName(ContentType type);

// A streamed message's envelope: one flags byte (bit 0: compressed, bit 1:
// the end-of-stream message) and the payload's length, 4 bytes big-endian.
inline constexpr uint8_t kEnvelopeCompressed = 0x01;
inline constexpr uint8_t kEnvelopeEndStream = 0x02;
inline constexpr size_t kEnvelopeHeaderBytes = 5;
std::string Envelope(uint8_t flags, absl::string_view payload);
// The end-of-stream message's JSON for `status`: {} or {"error": {...}}.
std::string EndStreamJson(const absl::Status& status);

// The one message a server-streaming request's body holds: exactly one
// envelope, not compressed, not end-of-stream, its declared length checked
// against `max_bytes` and against what the body holds. INVALID_ARGUMENT
// naming what is wrong.
absl::StatusOr<absl::string_view> ParseRequestEnvelope(absl::string_view body,
                                                       size_t max_bytes);

// Connect-Timeout-Ms: at most 10 ASCII digits (the spec's limit), a
// positive number of milliseconds. INVALID_ARGUMENT otherwise.
absl::StatusOr<absl::Duration> ParseTimeoutMs(absl::string_view header);

}  // namespace hdrstereo::http

#endif  // HDRSTEREO_DAEMON_HTTP_CONNECT_PROTOCOL_H_
