// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/http/connect_protocol.h"

#include "absl/algorithm/container.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "nlohmann/json.hpp"

namespace hdrstereo::http {

absl::string_view ConnectCodeName(absl::StatusCode code) {
  switch (code) {
    case absl::StatusCode::kOk:
      return "ok";
    case absl::StatusCode::kCancelled:
      return "canceled";
    case absl::StatusCode::kUnknown:
      return "unknown";
    case absl::StatusCode::kInvalidArgument:
      return "invalid_argument";
    case absl::StatusCode::kDeadlineExceeded:
      return "deadline_exceeded";
    case absl::StatusCode::kNotFound:
      return "not_found";
    case absl::StatusCode::kAlreadyExists:
      return "already_exists";
    case absl::StatusCode::kPermissionDenied:
      return "permission_denied";
    case absl::StatusCode::kResourceExhausted:
      return "resource_exhausted";
    case absl::StatusCode::kFailedPrecondition:
      return "failed_precondition";
    case absl::StatusCode::kAborted:
      return "aborted";
    case absl::StatusCode::kOutOfRange:
      return "out_of_range";
    case absl::StatusCode::kUnimplemented:
      return "unimplemented";
    case absl::StatusCode::kInternal:
      return "internal";
    case absl::StatusCode::kUnavailable:
      return "unavailable";
    case absl::StatusCode::kDataLoss:
      return "data_loss";
    case absl::StatusCode::kUnauthenticated:
      return "unauthenticated";
    default:
      return "unknown";
  }
}

int HttpStatusOf(absl::StatusCode code) {
  switch (code) {
    case absl::StatusCode::kOk:
      return 200;
    case absl::StatusCode::kCancelled:
      return 499;
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kOutOfRange:
      return 400;
    case absl::StatusCode::kDeadlineExceeded:
      return 504;
    case absl::StatusCode::kNotFound:
      return 404;
    case absl::StatusCode::kAlreadyExists:
    case absl::StatusCode::kAborted:
      return 409;
    case absl::StatusCode::kPermissionDenied:
      return 403;
    case absl::StatusCode::kResourceExhausted:
      return 429;
    case absl::StatusCode::kUnimplemented:
      return 501;
    case absl::StatusCode::kUnavailable:
      return 503;
    case absl::StatusCode::kUnauthenticated:
      return 401;
    default:
      return 500;
  }
}

namespace {

nlohmann::json ErrorObject(const absl::Status& status) {
  nlohmann::json error = {{"code", ConnectCodeName(status.code())}};
  if (!status.message().empty()) error["message"] = status.message();
  return error;
}

// nlohmann's dump throws on invalid UTF-8 unless told to replace it; gRPC
// messages may quote received bytes.
std::string Dump(const nlohmann::json& json) {
  return json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace

std::string ErrorJson(const absl::Status& status) {
  if (status.ok()) return "{}";
  return Dump(ErrorObject(status));
}

std::optional<ContentType> ParseContentType(absl::string_view header) {
  absl::string_view type = header;
  absl::string_view parameters;
  if (size_t semicolon = type.find(';'); semicolon != type.npos) {
    parameters = absl::StripAsciiWhitespace(type.substr(semicolon + 1));
    type = type.substr(0, semicolon);
  }
  type = absl::StripAsciiWhitespace(type);
  std::optional<ContentType> parsed;
  if (absl::EqualsIgnoreCase(type, "application/json")) {
    parsed = ContentType{Codec::kJson, false};
  } else if (absl::EqualsIgnoreCase(type, "application/proto")) {
    parsed = ContentType{Codec::kProto, false};
  } else if (absl::EqualsIgnoreCase(type, "application/connect+json")) {
    parsed = ContentType{Codec::kJson, true};
  } else if (absl::EqualsIgnoreCase(type, "application/connect+proto")) {
    parsed = ContentType{Codec::kProto, true};
  }
  if (!parsed.has_value() || parameters.empty()) return parsed;
  // JSON is UTF-8 by definition; a binary body has no charset.
  if (parsed->codec == Codec::kJson &&
      (absl::EqualsIgnoreCase(parameters, "charset=utf-8") ||
       absl::EqualsIgnoreCase(parameters, "charset=\"utf-8\""))) {
    return parsed;
  }
  return std::nullopt;
}

std::string ContentTypeName(ContentType type) {
  const char* codec = type.codec == Codec::kJson ? "json" : "proto";
  return absl::StrCat("application/", type.streaming ? "connect+" : "", codec);
}

std::string Envelope(uint8_t flags, absl::string_view payload) {
  const uint32_t size = static_cast<uint32_t>(payload.size());
  std::string envelope;
  envelope.reserve(kEnvelopeHeaderBytes + payload.size());
  envelope.push_back(static_cast<char>(flags));
  for (int shift = 24; shift >= 0; shift -= 8) {
    envelope.push_back(static_cast<char>((size >> shift) & 0xff));
  }
  envelope.append(payload.data(), payload.size());
  return envelope;
}

std::string EndStreamJson(const absl::Status& status) {
  if (status.ok()) return "{}";
  return Dump(nlohmann::json{{"error", ErrorObject(status)}});
}

absl::StatusOr<absl::string_view> ParseRequestEnvelope(absl::string_view body,
                                                       size_t max_bytes) {
  if (body.size() < kEnvelopeHeaderBytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        "a streaming call's body is one enveloped message (5-byte prefix, "
        "then the message); this one has ",
        body.size(), " bytes"));
  }
  const auto flags = static_cast<uint8_t>(body[0]);
  uint32_t size = 0;
  for (size_t i = 1; i < kEnvelopeHeaderBytes; ++i) {
    size = (size << 8) | static_cast<uint8_t>(body[i]);
  }
  if (flags != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("the request's envelope has flags ", flags,
                     "; hdrstereod takes one uncompressed message (flags 0)"));
  }
  if (size > max_bytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("the request's envelope declares ", size,
                     " bytes, more than the limit of ", max_bytes));
  }
  if (body.size() - kEnvelopeHeaderBytes != size) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the request's envelope declares ", size, " bytes but the body holds ",
        body.size() - kEnvelopeHeaderBytes,
        " after the prefix (exactly one message is expected)"));
  }
  return body.substr(kEnvelopeHeaderBytes);
}

absl::StatusOr<absl::Duration> ParseTimeoutMs(absl::string_view header) {
  int64_t ms = 0;
  if (header.empty() || header.size() > 10 ||
      !absl::c_all_of(header, absl::ascii_isdigit) ||
      !absl::SimpleAtoi(header, &ms) || ms <= 0) {
    return absl::InvalidArgumentError(
        "Connect-Timeout-Ms must be a positive whole number of milliseconds "
        "(at most 10 digits)");
  }
  return absl::Milliseconds(ms);
}

}  // namespace hdrstereo::http
