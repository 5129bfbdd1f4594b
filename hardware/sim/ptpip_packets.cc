// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/ptpip_packets.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace hdrstereo::sim::ptpip {
namespace {

uint32_t LoadU32(absl::string_view bytes, size_t at) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) {
    v = (v << 8) | static_cast<uint8_t>(bytes[at + i]);
  }
  return v;
}

uint16_t LoadU16(absl::string_view bytes, size_t at) {
  return static_cast<uint16_t>(static_cast<uint8_t>(bytes[at]) |
                               static_cast<uint8_t>(bytes[at + 1]) << 8);
}

void PutLittleEndian(std::string& out, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) {
    out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  }
}

std::string Framed(uint32_t type, absl::string_view body) {
  std::string out;
  out.reserve(kHeaderBytes + body.size());
  PutLittleEndian(out, kHeaderBytes + body.size(), 4);
  PutLittleEndian(out, type, 4);
  out.append(body.data(), body.size());
  return out;
}

// A response's or an event's body: code, transaction, parameters.
std::string CodeAndParams(uint16_t code, uint32_t transaction,
                          const std::vector<uint32_t>& params) {
  std::string body;
  PutLittleEndian(body, code, 2);
  PutLittleEndian(body, transaction, 4);
  for (uint32_t p : params) PutLittleEndian(body, p, 4);
  return body;
}

absl::Status Short(absl::string_view what, size_t need, size_t have) {
  return absl::InvalidArgumentError(absl::StrCat(
      what, " needs at least ", need, " bytes after the header, got ", have));
}

}  // namespace

absl::StatusOr<std::optional<Packet>> PacketReader::Next() {
  if (failed_) {
    return absl::FailedPreconditionError(
        "the stream had a bad packet length; nothing after it can be read");
  }
  if (buffer_.size() < kHeaderBytes) return std::nullopt;
  const uint32_t length = LoadU32(buffer_, 0);
  if (length < kHeaderBytes || length > max_packet_bytes_) {
    failed_ = true;
    return absl::InvalidArgumentError(
        absl::StrCat("a packet declares ", length, " bytes; a packet is ",
                     kHeaderBytes, " to ", max_packet_bytes_, " bytes here"));
  }
  if (buffer_.size() < length) return std::nullopt;
  ptpip::Packet packet;
  packet.type = LoadU32(buffer_, 4);
  packet.body = buffer_.substr(kHeaderBytes, length - kHeaderBytes);
  buffer_.erase(0, length);
  return packet;
}

absl::StatusOr<InitCommandRequest> ParseInitCommandRequest(
    absl::string_view body) {
  // GUID, a zero-terminated UCS-2 name (at least the zero), the version.
  constexpr size_t kMin = 16 + 2 + 4;
  if (body.size() < kMin) return Short("InitCommandRequest", kMin, body.size());
  if (body.size() % 2 != 0) {
    return absl::InvalidArgumentError(
        "InitCommandRequest has an odd length: its name is not UCS-2");
  }
  InitCommandRequest request;
  std::copy_n(body.begin(), 16, request.guid.begin());
  size_t at = 16;
  const size_t name_end = body.size() - 4;
  bool terminated = false;
  for (; at + 2 <= name_end; at += 2) {
    const uint16_t c = LoadU16(body, at);
    if (c == 0) {
      terminated = true;
      at += 2;
      break;
    }
    request.host_name.push_back(c < 0x80 ? static_cast<char>(c) : '?');
  }
  if (!terminated || at != name_end) {
    return absl::InvalidArgumentError(
        "InitCommandRequest's host name does not end in a zero character "
        "right before the version");
  }
  request.version = LoadU32(body, name_end);
  return request;
}

absl::StatusOr<uint32_t> ParseInitEventRequest(absl::string_view body) {
  if (body.size() != 4) {
    return absl::InvalidArgumentError(absl::StrCat(
        "InitEventRequest carries 4 bytes (a connection number), got ",
        body.size()));
  }
  return LoadU32(body, 0);
}

absl::StatusOr<OperationRequest> ParseOperationRequest(absl::string_view body) {
  constexpr size_t kMin = 4 + 2 + 4;
  if (body.size() < kMin) return Short("OperationRequest", kMin, body.size());
  const size_t param_bytes = body.size() - kMin;
  if (param_bytes % 4 != 0 || param_bytes > 5 * 4) {
    return absl::InvalidArgumentError(absl::StrCat(
        "OperationRequest carries ", param_bytes,
        " bytes of parameters; it takes 0 to 5 parameters of 4 bytes"));
  }
  OperationRequest request;
  request.data_phase = LoadU32(body, 0);
  if (request.data_phase != kNoDataOrToClient &&
      request.data_phase != kFromClient) {
    return absl::InvalidArgumentError(absl::StrCat(
        "OperationRequest announces data phase ", request.data_phase,
        "; it is 1 (none or to the client) "
        "or 2 (from the client)"));
  }
  request.code = LoadU16(body, 4);
  request.transaction = LoadU32(body, 6);
  for (size_t at = kMin; at < body.size(); at += 4) {
    request.params.push_back(LoadU32(body, at));
  }
  return request;
}

absl::StatusOr<StartData> ParseStartData(absl::string_view body) {
  if (body.size() != 12) {
    return absl::InvalidArgumentError(absl::StrCat(
        "StartData carries 12 bytes (transaction, u64 length), got ",
        body.size()));
  }
  StartData start;
  start.transaction = LoadU32(body, 0);
  start.total_bytes = static_cast<uint64_t>(LoadU32(body, 4)) |
                      static_cast<uint64_t>(LoadU32(body, 8)) << 32;
  return start;
}

absl::StatusOr<DataChunk> ParseDataChunk(absl::string_view body) {
  if (body.size() < 4) return Short("a data packet", 4, body.size());
  DataChunk chunk;
  chunk.transaction = LoadU32(body, 0);
  chunk.payload = body.substr(4);
  return chunk;
}

std::string InitCommandAckPacket(uint32_t connection,
                                 const std::array<uint8_t, 16>& guid,
                                 absl::string_view name) {
  std::string body;
  PutLittleEndian(body, connection, 4);
  body.append(reinterpret_cast<const char*>(guid.data()), guid.size());
  for (char c : name) {
    PutLittleEndian(body, static_cast<uint8_t>(c) < 0x80 ? c : '?', 2);
  }
  PutLittleEndian(body, 0, 2);           // libgphoto2 reads the name up to this
  PutLittleEndian(body, 0x00010000, 4);  // version 1.0
  return Framed(kInitCommandAck, body);
}

std::string InitEventAckPacket() { return Framed(kInitEventAck, ""); }

std::string ProbeResponsePacket() { return Framed(kProbeResponse, ""); }

std::string InitFailPacket(uint32_t reason) {
  std::string body;
  PutLittleEndian(body, reason, 4);
  return Framed(kInitFail, body);
}

std::string OperationResponsePacket(uint16_t code, uint32_t transaction,
                                    const std::vector<uint32_t>& params) {
  return Framed(kOperationResponse, CodeAndParams(code, transaction, params));
}

std::string EventPacket(uint16_t code, uint32_t transaction,
                        const std::vector<uint32_t>& params) {
  return Framed(kEvent, CodeAndParams(code, transaction, params));
}

std::string StartDataPacket(uint32_t transaction, uint64_t total_bytes) {
  std::string body;
  PutLittleEndian(body, transaction, 4);
  PutLittleEndian(body, total_bytes, 8);
  return Framed(kStartData, body);
}

std::string DataPacket(uint32_t transaction, absl::string_view payload,
                       bool last) {
  std::string body;
  body.reserve(4 + payload.size());
  PutLittleEndian(body, transaction, 4);
  body.append(payload.data(), payload.size());
  return Framed(last ? kEndData : kData, body);
}

DatasetWriter& DatasetWriter::U8(uint8_t v) {
  PutLittleEndian(bytes_, v, 1);
  return *this;
}
DatasetWriter& DatasetWriter::U16(uint16_t v) {
  PutLittleEndian(bytes_, v, 2);
  return *this;
}
DatasetWriter& DatasetWriter::U32(uint32_t v) {
  PutLittleEndian(bytes_, v, 4);
  return *this;
}
DatasetWriter& DatasetWriter::U64(uint64_t v) {
  PutLittleEndian(bytes_, v, 8);
  return *this;
}

DatasetWriter& DatasetWriter::String(absl::string_view ascii) {
  if (ascii.empty()) return U8(0);  // the empty string has no terminator
  ascii = ascii.substr(0, 254);
  U8(static_cast<uint8_t>(ascii.size() + 1));
  for (char c : ascii) U16(static_cast<uint8_t>(c) < 0x80 ? c : '?');
  return U16(0);
}

DatasetWriter& DatasetWriter::U16Array(const std::vector<uint16_t>& values) {
  U32(static_cast<uint32_t>(values.size()));
  for (uint16_t v : values) U16(v);
  return *this;
}

DatasetWriter& DatasetWriter::U32Array(const std::vector<uint32_t>& values) {
  U32(static_cast<uint32_t>(values.size()));
  for (uint32_t v : values) U32(v);
  return *this;
}

absl::StatusOr<uint32_t> ParseUnsignedValue(uint16_t data_type,
                                            absl::string_view data) {
  size_t size = 0;
  switch (data_type) {
    case type::kUint8:
      size = 1;
      break;
    case type::kUint16:
      size = 2;
      break;
    case type::kUint32:
      size = 4;
      break;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("data type 0x", absl::Hex(data_type),
                       " is not an unsigned integer of 1, 2 or 4 bytes"));
  }
  if (data.size() != size) {
    return absl::InvalidArgumentError(absl::StrCat(
        "a value of ", size, " bytes was expected, got ", data.size()));
  }
  uint32_t v = 0;
  for (size_t i = size; i-- > 0;) v = (v << 8) | static_cast<uint8_t>(data[i]);
  return v;
}

}  // namespace hdrstereo::sim::ptpip
