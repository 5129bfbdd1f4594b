// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/ptpip_packets.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace hdrstereo::sim::ptpip {
namespace {

using ::testing::HasSubstr;

std::string Le32(uint32_t v) {
  std::string out;
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
  return out;
}

std::string Le16(uint16_t v) {
  return std::string{static_cast<char>(v & 0xFF), static_cast<char>(v >> 8)};
}

TEST(PtpIpPacketReaderTest, SplitsAStreamFedInPiecesIntoPackets) {
  const std::string stream =
      OperationResponsePacket(rc::kOk, 7, {1, 2}) + InitEventAckPacket();
  PacketReader reader;
  // One byte at a time: a packet comes out only once it is whole.
  int packets = 0;
  for (char c : stream) {
    reader.Append(std::string(1, c));
    absl::StatusOr<std::optional<Packet>> next = reader.Next();
    ASSERT_TRUE(next.ok()) << next.status();
    if (next->has_value()) {
      ++packets;
      if (packets == 1) {
        EXPECT_EQ((*next)->type, kOperationResponse);
        EXPECT_EQ((*next)->body, Le16(rc::kOk) + Le32(7) + Le32(1) + Le32(2));
      } else {
        EXPECT_EQ((*next)->type, kInitEventAck);
        EXPECT_EQ((*next)->body, "");
      }
    }
  }
  EXPECT_EQ(packets, 2);
  EXPECT_EQ(reader.pending(), 0u);
}

TEST(PtpIpPacketReaderTest, RefusesAnAbsurdLengthBeforeAllocatingIt) {
  PacketReader reader(1024);
  reader.Append(Le32(0xFFFFFFF0) + Le32(kData));
  absl::StatusOr<std::optional<Packet>> next = reader.Next();
  EXPECT_EQ(next.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(next.status().message(),
              HasSubstr("declares 4294967280 bytes; a packet is 8 to 1024"));
  // Nothing after a bad length can be framed.
  reader.Append(InitEventAckPacket());
  EXPECT_EQ(reader.Next().status().code(),
            absl::StatusCode::kFailedPrecondition);

  PacketReader short_length;
  short_length.Append(Le32(4) + Le32(kData));
  EXPECT_EQ(short_length.Next().status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(PtpIpPacketsTest, ParsesAnInitCommandRequestAsLibgphoto2SendsIt) {
  std::string body(16, '\x11');  // GUID
  for (char c : std::string("lab-pc")) body += Le16(static_cast<uint8_t>(c));
  body += Le16(0) + Le32(0x00010000);
  absl::StatusOr<InitCommandRequest> request = ParseInitCommandRequest(body);
  ASSERT_TRUE(request.ok()) << request.status();
  EXPECT_EQ(request->host_name, "lab-pc");
  EXPECT_EQ(request->version, 0x00010000u);
  EXPECT_EQ(request->guid[15], 0x11);

  // A name without its zero, a name that runs into the version, an odd
  // length: refused, saying why.
  std::string unterminated(16, '\0');
  unterminated += Le16('a') + Le16('b') + Le32(0x00010000);
  EXPECT_THAT(ParseInitCommandRequest(unterminated).status().message(),
              HasSubstr("does not end in a zero character"));
  EXPECT_EQ(ParseInitCommandRequest(body + "x").status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(ParseInitCommandRequest("short").status().message(),
              HasSubstr("needs at least 22 bytes"));
}

TEST(PtpIpPacketsTest, ParsesOperationRequestsAndRefusesMalformedOnes) {
  const std::string base =
      Le32(kNoDataOrToClient) + Le16(op::kGetObject) + Le32(9);
  absl::StatusOr<OperationRequest> request =
      ParseOperationRequest(base + Le32(42));
  ASSERT_TRUE(request.ok()) << request.status();
  EXPECT_EQ(request->code, op::kGetObject);
  EXPECT_EQ(request->transaction, 9u);
  EXPECT_THAT(request->params, ::testing::ElementsAre(42u));

  EXPECT_THAT(ParseOperationRequest(base + "abc").status().message(),
              HasSubstr("3 bytes of parameters"));
  EXPECT_THAT(
      ParseOperationRequest(base + std::string(24, '\0')).status().message(),
      HasSubstr("0 to 5 parameters"));
  EXPECT_THAT(ParseOperationRequest(Le32(7) + Le16(op::kGetObject) + Le32(1))
                  .status()
                  .message(),
              HasSubstr("data phase 7"));
  EXPECT_EQ(ParseOperationRequest("").status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(PtpIpPacketsTest, ReadsDataPhasesWithTheirDeclaredLength) {
  absl::StatusOr<StartData> start =
      ParseStartData(Le32(3) + Le32(0) + Le32(1));  // 4 GiB announced
  ASSERT_TRUE(start.ok()) << start.status();
  EXPECT_EQ(start->transaction, 3u);
  EXPECT_EQ(start->total_bytes, uint64_t{1} << 32);
  EXPECT_EQ(ParseStartData(Le32(3)).status().code(),
            absl::StatusCode::kInvalidArgument);

  absl::StatusOr<DataChunk> chunk = ParseDataChunk(Le32(3) + "value");
  ASSERT_TRUE(chunk.ok()) << chunk.status();
  EXPECT_EQ(chunk->payload, "value");
  EXPECT_EQ(ParseDataChunk("ab").status().code(),
            absl::StatusCode::kInvalidArgument);

  EXPECT_EQ(*ParseUnsignedValue(type::kUint32, Le32(250)), 250u);
  EXPECT_EQ(*ParseUnsignedValue(type::kUint16, Le16(400)), 400u);
  EXPECT_THAT(ParseUnsignedValue(type::kUint16, Le32(400)).status().message(),
              HasSubstr("2 bytes was expected, got 4"));
  EXPECT_EQ(ParseUnsignedValue(type::kString, "").status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(PtpIpPacketsTest, WritesPacketsAndDatasetsInPtpsLayout) {
  std::array<uint8_t, 16> guid{};
  const std::string ack = InitCommandAckPacket(5, guid, "cam");
  // length, type, connection, GUID, "cam" + zero in UCS-2, version.
  ASSERT_EQ(ack.size(), 8u + 4 + 16 + 8 + 4);
  EXPECT_EQ(ack.substr(0, 8), Le32(40) + Le32(kInitCommandAck));
  EXPECT_EQ(ack.substr(28, 8), Le16('c') + Le16('a') + Le16('m') + Le16(0));

  const std::string data = DataPacket(4, "xyz", /*last=*/true);
  EXPECT_EQ(data, Le32(15) + Le32(kEndData) + Le32(4) + "xyz");
  EXPECT_EQ(StartDataPacket(4, 3),
            Le32(20) + Le32(kStartData) + Le32(4) + Le32(3) + Le32(0));

  DatasetWriter w;
  w.String("").String("ab").U16Array({1, 2});
  EXPECT_EQ(w.bytes(), std::string(1, '\0') + "\x03" + Le16('a') + Le16('b') +
                           Le16(0) + Le32(2) + Le16(1) + Le16(2));
}

}  // namespace
}  // namespace hdrstereo::sim::ptpip
