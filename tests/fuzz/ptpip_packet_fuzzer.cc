// SPDX-License-Identifier: GPL-3.0-or-later
// What a PTP/IP client sends the simulated network camera
// (hardware/sim/ptpip_camera.h): a byte stream framed into packets, each
// body parsed by its type. The first byte chooses how the stream is cut
// into reads, as TCP may deliver it in any pieces.
#include <string>

#include "hardware/sim/ptpip_packets.h"
#include "tests/fuzz/fuzz_support.h"

namespace ptpip = hdrstereo::sim::ptpip;

namespace {

void ParseBody(const ptpip::Packet& packet) {
  switch (packet.type) {
    case ptpip::kInitCommandRequest: {
      auto request = ptpip::ParseInitCommandRequest(packet.body);
      if (request.ok()) {
        FUZZ_CHECK(request->host_name.size() * 2 + 22 <= packet.body.size());
      }
      break;
    }
    case ptpip::kInitEventRequest:
      (void)ptpip::ParseInitEventRequest(packet.body);
      break;
    case ptpip::kOperationRequest: {
      auto request = ptpip::ParseOperationRequest(packet.body);
      if (request.ok()) {
        FUZZ_CHECK(request->params.size() <= 5);
        FUZZ_CHECK(request->data_phase == ptpip::kNoDataOrToClient ||
                   request->data_phase == ptpip::kFromClient);
      }
      break;
    }
    case ptpip::kStartData:
      (void)ptpip::ParseStartData(packet.body);
      break;
    case ptpip::kData:
    case ptpip::kEndData: {
      auto chunk = ptpip::ParseDataChunk(packet.body);
      if (chunk.ok()) {
        FUZZ_CHECK(chunk->payload.size() + 4 == packet.body.size());
        for (uint16_t type : {ptpip::type::kUint8, ptpip::type::kUint16,
                              ptpip::type::kUint32}) {
          (void)ptpip::ParseUnsignedValue(type, chunk->payload);
        }
      }
      break;
    }
    default:
      break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const size_t piece = 1 + data[0] % 64;
  const absl::string_view stream = hdrstereo::fuzz::AsText(data + 1, size - 1);
  ptpip::PacketReader reader(4096);
  size_t framed = 0;
  for (size_t at = 0; at < stream.size(); at += piece) {
    reader.Append(stream.substr(at, piece));
    while (true) {
      auto next = reader.Next();
      if (!next.ok()) return 0;  // a bad length ends the stream
      if (!next->has_value()) break;
      const ptpip::Packet& packet = **next;
      framed += ptpip::kHeaderBytes + packet.body.size();
      FUZZ_CHECK(packet.body.size() + ptpip::kHeaderBytes <= 4096);
      ParseBody(packet);
    }
  }
  // Every byte is either in a packet or still waiting for the rest of one.
  FUZZ_CHECK(framed + reader.pending() == stream.size());
  return 0;
}
