// SPDX-License-Identifier: GPL-3.0-or-later
//
// nlohmann::json's messages about received text keep their explanation and
// position, and quote only a bounded prefix of what they read.
#include "processing/io/json_input.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

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

TEST(JsonErrorTest, OtherMessagesAreUnchanged) {
  EXPECT_EQ(BoundedJsonError("[json.exception.type_error.302] type must be "
                             "string, but is number"),
            "[json.exception.type_error.302] type must be string, but is "
            "number");
}

}  // namespace
}  // namespace hdrstereo::io
