// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Connect protocol's wire shapes as the HTTP edge speaks them: every
// code's name and HTTP status (the spec's table), the error body with the
// message unchanged, the content types a request may have (none an HTML
// form can send), the 5-byte envelope and Connect-Timeout-Ms.
#include "daemon/http/connect_protocol.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "nlohmann/json.hpp"
#include "tests/support/status_matchers.h"

namespace hdrstereo::http {
namespace {

using ::hdrstereo::testing::StatusIs;

struct CodeRow {
  absl::StatusCode code;
  const char* name;
  int http_status;
};

// connectrpc.com/docs/protocol#error-codes.
const CodeRow kConnectCodes[] = {
    {absl::StatusCode::kCancelled, "canceled", 499},
    {absl::StatusCode::kUnknown, "unknown", 500},
    {absl::StatusCode::kInvalidArgument, "invalid_argument", 400},
    {absl::StatusCode::kDeadlineExceeded, "deadline_exceeded", 504},
    {absl::StatusCode::kNotFound, "not_found", 404},
    {absl::StatusCode::kAlreadyExists, "already_exists", 409},
    {absl::StatusCode::kPermissionDenied, "permission_denied", 403},
    {absl::StatusCode::kResourceExhausted, "resource_exhausted", 429},
    {absl::StatusCode::kFailedPrecondition, "failed_precondition", 400},
    {absl::StatusCode::kAborted, "aborted", 409},
    {absl::StatusCode::kOutOfRange, "out_of_range", 400},
    {absl::StatusCode::kUnimplemented, "unimplemented", 501},
    {absl::StatusCode::kInternal, "internal", 500},
    {absl::StatusCode::kUnavailable, "unavailable", 503},
    {absl::StatusCode::kDataLoss, "data_loss", 500},
    {absl::StatusCode::kUnauthenticated, "unauthenticated", 401},
};

TEST(ConnectCodeTest, EveryCodeHasTheSpecsNameAndHttpStatus) {
  for (const CodeRow& row : kConnectCodes) {
    EXPECT_EQ(ConnectCodeName(row.code), row.name)
        << absl::StatusCodeToString(row.code);
    EXPECT_EQ(HttpStatusOf(row.code), row.http_status)
        << absl::StatusCodeToString(row.code);
  }
  EXPECT_EQ(HttpStatusOf(absl::StatusCode::kOk), 200);
}

TEST(ConnectCodeTest, ACodeOutsideAbslsListIsUnknown) {
  const auto code = static_cast<absl::StatusCode>(42);
  EXPECT_EQ(ConnectCodeName(code), "unknown");
  EXPECT_EQ(HttpStatusOf(code), 500);
}

TEST(ErrorJsonTest, IsTheCodeAndTheMessage) {
  EXPECT_EQ(ErrorJson(absl::PermissionDeniedError("operator role needed")),
            R"({"code":"permission_denied","message":"operator role needed"})");
  EXPECT_EQ(ErrorJson(absl::OkStatus()), "{}");
  // An empty message is left out, as the spec allows.
  EXPECT_EQ(ErrorJson(absl::Status(absl::StatusCode::kNotFound, "")),
            R"({"code":"not_found"})");
}

TEST(ErrorJsonTest, KeepsTheMessageUnchangedWhateverItHolds) {
  const std::string message =
      "a \"quoted\" name,\na newline, a tab\t, a backslash \\, a NUL \0 and "
      "</script>";
  const std::string with_nul(message.data(), message.size());
  const nlohmann::json parsed =
      nlohmann::json::parse(ErrorJson(absl::InvalidArgumentError(with_nul)));
  EXPECT_EQ(parsed.at("code"), "invalid_argument");
  EXPECT_EQ(parsed.at("message").get<std::string>(), with_nul);
}

TEST(ErrorJsonTest, InvalidUtf8IsReplacedNotThrown) {
  // gRPC messages may quote received bytes: a lone continuation byte and a
  // truncated sequence become U+FFFD each; the rest stays.
  const std::string json =
      ErrorJson(absl::InvalidArgumentError("bad \x80 and \xE2\x82 end"));
  const nlohmann::json parsed = nlohmann::json::parse(json);
  EXPECT_EQ(parsed.at("message").get<std::string>(),
            "bad \xEF\xBF\xBD and \xEF\xBF\xBD end");
}

TEST(EndStreamJsonTest, IsEmptyOnSuccessAndTheErrorOtherwise) {
  EXPECT_EQ(EndStreamJson(absl::OkStatus()), "{}");
  EXPECT_EQ(EndStreamJson(absl::DeadlineExceededError("too slow\n\xff")),
            "{\"error\":{\"code\":\"deadline_exceeded\",\"message\":\"too "
            "slow\\n\xEF\xBF\xBD\"}}");
}

TEST(ContentTypeTest, TheFourConnectTypesAreRead) {
  const std::vector<std::pair<const char*, ContentType>> cases = {
      {"application/json", {Codec::kJson, false}},
      {"application/proto", {Codec::kProto, false}},
      {"application/connect+json", {Codec::kJson, true}},
      {"application/connect+proto", {Codec::kProto, true}},
      {"Application/JSON", {Codec::kJson, false}},
      {"  application/connect+proto  ", {Codec::kProto, true}},
  };
  for (const auto& [header, expected] : cases) {
    const std::optional<ContentType> parsed = ParseContentType(header);
    ASSERT_TRUE(parsed.has_value()) << header;
    EXPECT_EQ(parsed->codec, expected.codec) << header;
    EXPECT_EQ(parsed->streaming, expected.streaming) << header;
  }
}

TEST(ContentTypeTest, ACharsetOfUtf8IsAllowedForJsonOnly) {
  for (const char* header :
       {"application/json; charset=utf-8", "application/json;charset=UTF-8",
        "application/json; charset=\"utf-8\"",
        "application/connect+json; charset=utf-8"}) {
    EXPECT_TRUE(ParseContentType(header).has_value()) << header;
  }
  for (const char* header :
       {"application/json; charset=latin1", "application/json; charset=utf-16",
        "application/json; charset=utf-8; boundary=x",
        "application/proto; charset=utf-8",
        "application/connect+proto; charset=utf-8"}) {
    EXPECT_FALSE(ParseContentType(header).has_value()) << header;
  }
}

TEST(ContentTypeTest, EveryTypeAnHtmlFormCanSendIsRefused) {
  // A cross-site form can send these three without a CORS preflight.
  for (const char* header :
       {"application/x-www-form-urlencoded", "multipart/form-data",
        "multipart/form-data; boundary=----x", "text/plain",
        "text/plain; charset=utf-8", "text/plain; application/json"}) {
    EXPECT_EQ(ParseContentType(header), std::nullopt) << header;
  }
}

TEST(ContentTypeTest, OtherTypesAndJunkAreRefused) {
  for (const char* header :
       {"", ";", "application/", "application/jsonx", "application/json+x",
        "application/grpc", "application/grpc+proto", "application/protobuf",
        "json", "application /json", "application/json\r\nX: y"}) {
    EXPECT_EQ(ParseContentType(header), std::nullopt) << header;
  }
}

TEST(ContentTypeTest, TheAnswersTypeIsNamedAsConnectNamesIt) {
  EXPECT_EQ(ContentTypeName({Codec::kJson, false}), "application/json");
  EXPECT_EQ(ContentTypeName({Codec::kProto, false}), "application/proto");
  EXPECT_EQ(ContentTypeName({Codec::kJson, true}), "application/connect+json");
  EXPECT_EQ(ContentTypeName({Codec::kProto, true}),
            "application/connect+proto");
}

TEST(EnvelopeTest, IsTheFlagsTheBigEndianLengthAndThePayload) {
  EXPECT_EQ(Envelope(0, "abc"), std::string("\0\0\0\0\3abc", 8));
  EXPECT_EQ(Envelope(kEnvelopeEndStream, ""), std::string("\2\0\0\0\0", 5));
  const std::string payload(0x010203, 'x');
  const std::string envelope = Envelope(kEnvelopeCompressed, payload);
  EXPECT_EQ(envelope.substr(0, kEnvelopeHeaderBytes),
            std::string("\1\0\1\2\3", 5));
  EXPECT_EQ(envelope.size(), kEnvelopeHeaderBytes + payload.size());
}

TEST(EnvelopeTest, WhatEnvelopeWritesParsesBack) {
  for (const std::string& payload :
       {std::string(), std::string("\0\xff{}", 4), std::string(255, 'a'),
        std::string(256, 'b'), std::string(70000, 'c')}) {
    const std::string body = Envelope(0, payload);
    ASSERT_OK_AND_ASSIGN(absl::string_view parsed,
                         ParseRequestEnvelope(body, payload.size()));
    EXPECT_EQ(parsed, payload) << payload.size();
  }
}

TEST(EnvelopeTest, FlagsAreRefused) {
  for (uint8_t flags :
       {kEnvelopeCompressed, kEnvelopeEndStream, uint8_t{3}, uint8_t{0x80}}) {
    EXPECT_THAT(
        ParseRequestEnvelope(Envelope(flags, "{}"), 100),
        StatusIs(absl::StatusCode::kInvalidArgument,
                 absl::StrCat("the request's envelope has flags ", flags,
                              "; hdrstereod takes one uncompressed message "
                              "(flags 0)")));
  }
}

TEST(EnvelopeTest, ADeclaredLengthOverTheLimitIsRefusedBeforeTheBodyIsRead) {
  EXPECT_THAT(ParseRequestEnvelope(Envelope(0, std::string(11, 'x')), 10),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "the request's envelope declares 11 bytes, more than "
                       "the limit of 10"));
  // 4 GiB - 1 declared in a 5-byte body.
  EXPECT_THAT(ParseRequestEnvelope(std::string("\0\xff\xff\xff\xff", 5), 10),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "the request's envelope declares 4294967295 bytes, "
                       "more than the limit of 10"));
}

TEST(EnvelopeTest, ATruncatedOrLongerBodyIsRefused) {
  EXPECT_THAT(ParseRequestEnvelope(std::string("\0\0\0\0\5abc", 8), 100),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "the request's envelope declares 5 bytes but the body "
                       "holds 3 after the prefix (exactly one message is "
                       "expected)"));
  // Two messages where a server-streaming call takes one.
  EXPECT_THAT(
      ParseRequestEnvelope(Envelope(0, "abc") + Envelope(0, "def"), 100),
      StatusIs(absl::StatusCode::kInvalidArgument,
               "the request's envelope declares 3 bytes but the body holds 11 "
               "after the prefix (exactly one message is expected)"));
}

TEST(EnvelopeTest, BodiesShorterThanThePrefixAreRefused) {
  for (size_t size = 0; size < kEnvelopeHeaderBytes; ++size) {
    EXPECT_THAT(ParseRequestEnvelope(std::string(size, '\0'), 100),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         absl::StrCat("a streaming call's body is one "
                                      "enveloped message (5-byte prefix, then "
                                      "the message); this one has ",
                                      size, " bytes")));
  }
}

TEST(TimeoutTest, PositiveWholeMillisecondsOfAtMostTenDigits) {
  const std::vector<std::pair<const char*, absl::Duration>> cases = {
      {"1", absl::Milliseconds(1)},
      {"2500", absl::Milliseconds(2500)},
      {"0000000007", absl::Milliseconds(7)},
      {"9999999999", absl::Milliseconds(9999999999)}};
  for (const auto& [header, expected] : cases) {
    ASSERT_OK_AND_ASSIGN(absl::Duration timeout, ParseTimeoutMs(header));
    EXPECT_EQ(timeout, expected) << header;
  }
}

TEST(TimeoutTest, AnythingElseIsRefused) {
  for (const std::string& header :
       {std::string(), std::string("0"), std::string("0000000000"),
        std::string("12345678901"), std::string("-5"), std::string("+5"),
        std::string(" 5"), std::string("5 "), std::string("1.5"),
        std::string("1e3"), std::string("0x10"), std::string("5ms"),
        std::string("5\0", 2), std::string("99999999999999999999")}) {
    EXPECT_THAT(ParseTimeoutMs(header),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         "Connect-Timeout-Ms must be a positive whole number "
                         "of milliseconds (at most 10 digits)"))
        << header;
  }
}

}  // namespace
}  // namespace hdrstereo::http
