// SPDX-License-Identifier: GPL-3.0-or-later
//
// nlohmann::json's messages about received text keep their explanation and
// position, and quote only a bounded prefix of what they read.
#include "processing/io/json_input.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "tests/support/status_matchers.h"

namespace hdrstereo::io {
namespace {

using ::testing::HasSubstr;

std::string ParseError(const std::string& text) {
  try {
    const nlohmann::json parsed = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    return BoundedJsonError(e.what());
  }
  return "parsed";
}

TEST(JsonErrorTest, AnUnterminatedStringIsQuotedBounded) {
  const std::string message = ParseError("[\"" + std::string(100000, 'a'));
  EXPECT_THAT(message, HasSubstr("parse error at line 1, column 100003: "
                                 "syntax error while parsing value - invalid "
                                 "string: missing closing quote; last read: "
                                 "\"\\\"aaaa"));
  EXPECT_THAT(message, HasSubstr("\"... (100001 bytes)"));
  EXPECT_LT(message.size(), 300u);
}

// The token is received text: "'; expected " inside it is not where it
// ends, so the rest of the file is still quoted bounded.
TEST(JsonErrorTest, ATokenHoldingExpectedIsQuotedBounded) {
  const std::string message =
      ParseError("[\"'; expected " + std::string(100000, 'a'));
  EXPECT_THAT(message, HasSubstr("missing closing quote; last read: "
                                 "\"\\\"\\'; expected aaaa"));
  EXPECT_THAT(message, HasSubstr("\"... (100013 bytes)"));
  EXPECT_LT(message.size(), 300u);
  // Made to end like nlohmann's own tail: the tail is kept, the token
  // before it still quoted bounded.
  const std::string tail =
      ParseError("[\"" + std::string(100000, 'a') + "'; expected ']");
  EXPECT_THAT(tail, HasSubstr("\"... (100001 bytes); expected ']'"));
  EXPECT_LT(tail.size(), 300u);
}

TEST(JsonErrorTest, WhatWasExpectedIsKept) {
  EXPECT_THAT(ParseError("[1] x"),
              HasSubstr("last read: \"1] x\"; expected end of input"));
  EXPECT_THAT(ParseError("{\"a\": tru"), HasSubstr("last read: \"\\\"a\\\": "
                                                   "tru\""));
}

TEST(JsonErrorTest, ANumberTooLargeIsQuotedBounded) {
  const std::string message = ParseError("[1" + std::string(5000, '0') + "]");
  EXPECT_THAT(message, HasSubstr("number overflow parsing \"1000"));
  EXPECT_THAT(message, HasSubstr("(5001 bytes)"));
  EXPECT_LT(message.size(), 300u);
}

TEST(JsonInt64Test, ReadsIntegersWithoutWrapping) {
  using nlohmann::json;
  EXPECT_EQ(JsonInt64(json::parse("42")), 42);
  EXPECT_EQ(JsonInt64(json::parse("-42")), -42);
  EXPECT_EQ(JsonInt64(json::parse("9223372036854775807")), INT64_MAX);
  EXPECT_EQ(JsonInt64(json::parse("9223372036854775808")), std::nullopt);
  EXPECT_EQ(JsonInt64(json::parse("18446744073709551615")), std::nullopt);
  EXPECT_EQ(JsonInt64(json::parse("-9223372036854775808")), INT64_MIN);
  EXPECT_EQ(JsonInt64(json::parse("1.5")), std::nullopt);
  EXPECT_EQ(JsonInt64(json::parse("\"1\"")), std::nullopt);
}

TEST(JsonIntInRangeTest, NamesTheFieldTheValueAndTheRange) {
  using ::hdrstereo::testing::StatusIs;
  using nlohmann::json;
  ASSERT_OK_AND_ASSIGN(const int64_t bits,
                       JsonIntInRange(json::parse("16"), "bits", 1, 16));
  EXPECT_EQ(bits, 16);
  EXPECT_THAT(JsonIntInRange(json::parse("17"), "bits", 1, 16),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "bits: 17 is outside [1, 16]"));
  EXPECT_THAT(
      JsonIntInRange(json::parse("-9223372036854775808"), "bits", 1, 16),
      StatusIs(absl::StatusCode::kInvalidArgument,
               "bits: -9223372036854775808 is outside [1, 16]"));
  // 2^64 - 1 is held as uint64 and would read as -1.
  EXPECT_THAT(JsonIntInRange(json::parse("18446744073709551615"), "n", -1, 1),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "n: 18446744073709551615 is outside [-1, 1]"));
  for (const char* not_integer : {"1.0", "\"1\"", "[1]", "null"}) {
    EXPECT_THAT(JsonIntInRange(json::parse(not_integer), "bits", 1, 16),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         "bits: expected an integer"))
        << not_integer;
  }
}

TEST(JsonErrorTest, OtherMessagesAreUnchanged) {
  EXPECT_EQ(BoundedJsonError("[json.exception.type_error.302] type must be "
                             "string, but is number"),
            "[json.exception.type_error.302] type must be string, but is "
            "number");
}

}  // namespace
}  // namespace hdrstereo::io
