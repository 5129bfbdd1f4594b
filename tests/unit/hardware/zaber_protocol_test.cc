// SPDX-License-Identifier: GPL-3.0-or-later
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hardware/zaber/protocol.h"

namespace hdrstereo::zaber {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(ZaberProtocolTest, FormatsCommands) {
  EXPECT_EQ(FormatCommand(1, 1, "move abs 1000"), "/1 1 move abs 1000\n");
  EXPECT_EQ(FormatCommand(2, 1, ""), "/2 1\n");
}

TEST(ZaberProtocolTest, ParsesIdleAndBusyReplies) {
  absl::StatusOr<Reply> idle = ParseReply("@01 1 OK IDLE -- 0\r\n");
  ASSERT_TRUE(idle.ok()) << idle.status();
  EXPECT_EQ(idle->device, 1);
  EXPECT_EQ(idle->axis, 1);
  EXPECT_FALSE(idle->rejected);
  EXPECT_FALSE(idle->busy);
  EXPECT_EQ(idle->warning, "");
  EXPECT_EQ(idle->data, "0");

  absl::StatusOr<Reply> busy = ParseReply("@02 1 OK BUSY WR 315000");
  ASSERT_TRUE(busy.ok());
  EXPECT_EQ(busy->device, 2);
  EXPECT_TRUE(busy->busy);
  EXPECT_EQ(busy->warning, "WR");
  EXPECT_EQ(busy->data, "315000");
}

TEST(ZaberProtocolTest, ParsesRejections) {
  absl::StatusOr<Reply> rejected = ParseReply("@01 1 RJ IDLE -- BADDATA");
  ASSERT_TRUE(rejected.ok());
  EXPECT_TRUE(rejected->rejected);
  EXPECT_EQ(rejected->data, "BADDATA");
}

TEST(ZaberProtocolTest, GarbageIsAnErrorNamingTheLine) {
  for (const char* garbage :
       {"", "@01 1 OK", "#01 1 OK IDLE -- 0", "@0x 1 OK IDLE -- 0",
        "@01 1 MAYBE IDLE -- 0", "@01 1 OK SLEEPY -- 0", "@01 1 OK IDLE - 0",
        "\x9f\x01@@@"}) {
    absl::StatusOr<Reply> reply = ParseReply(garbage);
    EXPECT_EQ(reply.status().code(), absl::StatusCode::kInvalidArgument)
        << garbage;
    EXPECT_THAT(std::string(reply.status().message()),
                HasSubstr("malformed Zaber reply"));
  }
}

// Limits: the line's length, device and axis numbers; garbage that is long
// is quoted as a bounded, escaped prefix.
TEST(ZaberProtocolTest, RepliesBeyondTheLimitsAreRefusedByName) {
  const std::string longest =
      "@01 1 OK IDLE -- " + std::string(kMaxReplyBytes - 17, '7');
  absl::StatusOr<Reply> at_limit = ParseReply(longest);
  ASSERT_TRUE(at_limit.ok()) << at_limit.status();
  EXPECT_EQ(at_limit->data.size(), kMaxReplyBytes - 17);
  absl::StatusOr<Reply> too_long = ParseReply(longest + "7");
  EXPECT_EQ(too_long.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(too_long.status().message()),
              HasSubstr("\"... (1025 bytes): the reply is 1025 bytes long; "
                        "the most is 1024"));
  EXPECT_LT(too_long.status().message().size(), 200u);

  struct Bad {
    std::string line;
    std::string says;
  };
  for (const Bad& bad : std::vector<Bad>{
           {"@00 1 OK IDLE -- 0", "device 0 is outside [1, 99]"},
           {"@100 1 OK IDLE -- 0", "device 100 is outside [1, 99]"},
           {"@01 10 OK IDLE -- 0", "axis 10 is outside [0, 9]"},
           {"@01 -1 OK IDLE -- 0", "axis -1 is outside [0, 9]"},
           {"@99999999999 1 OK IDLE -- 0", "device or axis is not a number"},
           {std::string("@01\0 1 OK IDLE -- 0", 19),
            "\"@01\\x00 1 OK IDLE -- 0\": device or axis is not a number"},
       }) {
    absl::StatusOr<Reply> reply = ParseReply(bad.line);
    EXPECT_EQ(reply.status().code(), absl::StatusCode::kInvalidArgument)
        << bad.line;
    EXPECT_THAT(std::string(reply.status().message()), HasSubstr(bad.says))
        << bad.line;
  }
  absl::StatusOr<Reply> device_scope = ParseReply("@99 0 OK IDLE -- 0");
  ASSERT_TRUE(device_scope.ok()) << device_scope.status();
  EXPECT_EQ(device_scope->device, 99);
  EXPECT_EQ(device_scope->axis, 0);
}

TEST(ZaberProtocolTest, WarningFlagsAreTwoCharactersAndBounded) {
  EXPECT_THAT(ParseWarningFlags("03 FS x WRONG WR"), ElementsAre("FS", "WR"));
  std::string many = "99";
  for (int i = 0; i < 500; ++i) many += " WR";
  EXPECT_EQ(ParseWarningFlags(many).size(), kMaxWarningFlags);
}

TEST(ZaberProtocolTest, WarningFlags) {
  EXPECT_THAT(ParseWarningFlags("02 FS WR"), ElementsAre("FS", "WR"));
  EXPECT_TRUE(ParseWarningFlags("00").empty());
  EXPECT_TRUE(IsFault("FS"));
  EXPECT_FALSE(IsFault("WR"));
  EXPECT_FALSE(IsFault(""));
  EXPECT_THAT(DescribeWarning("FS"), HasSubstr("stalled"));
  EXPECT_EQ(DescribeWarning("QQ"), "QQ");
}

}  // namespace
}  // namespace hdrstereo::zaber
