// SPDX-License-Identifier: GPL-3.0-or-later
#include <gmock/gmock.h>
#include <gtest/gtest.h>

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
