// SPDX-License-Identifier: GPL-3.0-or-later
//
// The wire format of PTP/IP (CIPA DC-005) and the PTP datasets (ISO 15740)
// that the simulated network camera (ptpip_camera.h) speaks: packets split
// out of a byte stream, each client packet parsed with every length
// checked, and the camera's packets and datasets written. All integers are
// little-endian; a packet is `u32 length` (the 8-byte header included),
// `u32 type`, then its body. docs/ptpip.md says what libgphoto2 expects.
#ifndef HDRSTEREO_HARDWARE_SIM_PTPIP_PACKETS_H_
#define HDRSTEREO_HARDWARE_SIM_PTPIP_PACKETS_H_

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::sim::ptpip {

enum PacketType : uint32_t {
  kInitCommandRequest = 1,
  kInitCommandAck = 2,
  kInitEventRequest = 3,
  kInitEventAck = 4,
  kInitFail = 5,
  kOperationRequest = 6,
  kOperationResponse = 7,
  kEvent = 8,
  kStartData = 9,
  kData = 10,
  kCancel = 11,
  kEndData = 12,
  kProbeRequest = 13,
  kProbeResponse = 14,
};

inline constexpr uint32_t kHeaderBytes = 8;
// The longest packet a client sends: an init request (a host name) or a
// data chunk of SetDevicePropValue (libgphoto2 sends at most 64 KiB).
inline constexpr uint32_t kMaxClientPacketBytes = 256 * 1024;
// The longest data phase a client may announce: a property value.
inline constexpr uint64_t kMaxClientDataBytes = 64 * 1024;

// ISO 15740 operation, response, event and property codes used here.
namespace op {
inline constexpr uint16_t kGetDeviceInfo = 0x1001;
inline constexpr uint16_t kOpenSession = 0x1002;
inline constexpr uint16_t kCloseSession = 0x1003;
inline constexpr uint16_t kGetStorageIds = 0x1004;
inline constexpr uint16_t kGetStorageInfo = 0x1005;
inline constexpr uint16_t kGetNumObjects = 0x1006;
inline constexpr uint16_t kGetObjectHandles = 0x1007;
inline constexpr uint16_t kGetObjectInfo = 0x1008;
inline constexpr uint16_t kGetObject = 0x1009;
inline constexpr uint16_t kDeleteObject = 0x100B;
inline constexpr uint16_t kInitiateCapture = 0x100E;
inline constexpr uint16_t kGetDevicePropDesc = 0x1014;
inline constexpr uint16_t kGetDevicePropValue = 0x1015;
inline constexpr uint16_t kSetDevicePropValue = 0x1016;
}  // namespace op

namespace rc {
inline constexpr uint16_t kOk = 0x2001;
inline constexpr uint16_t kGeneralError = 0x2002;
inline constexpr uint16_t kSessionNotOpen = 0x2003;
inline constexpr uint16_t kInvalidTransactionId = 0x2004;
inline constexpr uint16_t kOperationNotSupported = 0x2005;
inline constexpr uint16_t kParameterNotSupported = 0x2006;
inline constexpr uint16_t kInvalidStorageId = 0x2008;
inline constexpr uint16_t kInvalidObjectHandle = 0x2009;
inline constexpr uint16_t kDevicePropNotSupported = 0x200A;
inline constexpr uint16_t kAccessDenied = 0x200F;
inline constexpr uint16_t kDeviceBusy = 0x2019;
inline constexpr uint16_t kInvalidDevicePropValue = 0x201C;
inline constexpr uint16_t kInvalidParentObject = 0x201A;
inline constexpr uint16_t kSessionAlreadyOpen = 0x201E;
}  // namespace rc

namespace event {
inline constexpr uint16_t kObjectAdded = 0x4002;
inline constexpr uint16_t kDevicePropChanged = 0x4006;
inline constexpr uint16_t kStoreFull = 0x400A;
inline constexpr uint16_t kCaptureComplete = 0x400D;
}  // namespace event

namespace prop {
inline constexpr uint16_t kBatteryLevel = 0x5001;
inline constexpr uint16_t kFNumber = 0x5007;
inline constexpr uint16_t kExposureTime = 0x500D;
inline constexpr uint16_t kExposureIndex = 0x500F;
inline constexpr uint16_t kDateTime = 0x5011;
}  // namespace prop

// PTP data type codes.
namespace type {
inline constexpr uint16_t kUint8 = 0x0002;
inline constexpr uint16_t kUint16 = 0x0004;
inline constexpr uint16_t kUint32 = 0x0006;
inline constexpr uint16_t kString = 0xFFFF;
}  // namespace type

// One packet as read off a connection.
struct Packet {
  uint32_t type = 0;
  std::string body;  // after the header
};

// Splits a byte stream into packets. A declared length below the header's
// or above `max_packet_bytes` is an error before anything is allocated for
// it; the reader is then unusable (the connection must be closed: nothing
// after a bad length can be framed).
class PacketReader {
 public:
  explicit PacketReader(uint32_t max_packet_bytes = kMaxClientPacketBytes)
      : max_packet_bytes_(max_packet_bytes) {}
  void Append(absl::string_view bytes) {
    buffer_.append(bytes.data(), bytes.size());
  }
  // The next complete packet, nullopt until one is buffered. INVALID_ARGUMENT
  // naming the bad length.
  absl::StatusOr<std::optional<Packet>> Next();
  // Bytes buffered that are not yet a complete packet.
  size_t pending() const { return buffer_.size(); }

 private:
  const uint32_t max_packet_bytes_;
  std::string buffer_;
  bool failed_ = false;
};

// Client packets' bodies. Each returns INVALID_ARGUMENT saying what is short
// or malformed.
struct InitCommandRequest {
  std::array<uint8_t, 16> guid{};
  std::string host_name;  // UCS-2 decoded; characters above 0x7F become '?'
  uint32_t version = 0;   // major << 16 | minor
};
absl::StatusOr<InitCommandRequest> ParseInitCommandRequest(
    absl::string_view body);
// The connection number the event connection names.
absl::StatusOr<uint32_t> ParseInitEventRequest(absl::string_view body);

// The data phase an operation request announces.
enum DataPhase : uint32_t { kNoDataOrToClient = 1, kFromClient = 2 };
struct OperationRequest {
  uint32_t data_phase = kNoDataOrToClient;
  uint16_t code = 0;
  uint32_t transaction = 0;
  std::vector<uint32_t> params;  // at most 5
};
absl::StatusOr<OperationRequest> ParseOperationRequest(absl::string_view body);

struct StartData {
  uint32_t transaction = 0;
  uint64_t total_bytes = 0;
};
absl::StatusOr<StartData> ParseStartData(absl::string_view body);
// A Data or EndData body: the transaction, then the payload.
struct DataChunk {
  uint32_t transaction = 0;
  absl::string_view payload;  // into the parsed body
};
absl::StatusOr<DataChunk> ParseDataChunk(absl::string_view body);

// The camera's packets, header included.
std::string InitCommandAckPacket(uint32_t connection,
                                 const std::array<uint8_t, 16>& guid,
                                 absl::string_view name);
std::string InitEventAckPacket();
std::string InitFailPacket(uint32_t reason);
std::string ProbeResponsePacket();
std::string OperationResponsePacket(uint16_t code, uint32_t transaction,
                                    const std::vector<uint32_t>& params = {});
std::string EventPacket(uint16_t code, uint32_t transaction,
                        const std::vector<uint32_t>& params = {});
std::string StartDataPacket(uint32_t transaction, uint64_t total_bytes);
// Data (`last` false) or EndData (`last` true).
std::string DataPacket(uint32_t transaction, absl::string_view payload,
                       bool last);

// Builds a PTP dataset (little-endian; strings as PTP strings: a count of
// UCS-2 characters including the terminating zero, then the characters;
// arrays as a u32 count, then the elements).
class DatasetWriter {
 public:
  DatasetWriter& U8(uint8_t v);
  DatasetWriter& U16(uint16_t v);
  DatasetWriter& U32(uint32_t v);
  DatasetWriter& U64(uint64_t v);
  // ASCII (other bytes become '?'); at most 254 characters are kept.
  DatasetWriter& String(absl::string_view ascii);
  DatasetWriter& U16Array(const std::vector<uint16_t>& values);
  DatasetWriter& U32Array(const std::vector<uint32_t>& values);
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

// Reads a value of a PTP data type (kUint8/16/32) from a client's data
// phase: INVALID_ARGUMENT when `data` is not exactly that long or the type
// is another.
absl::StatusOr<uint32_t> ParseUnsignedValue(uint16_t data_type,
                                            absl::string_view data);

}  // namespace hdrstereo::sim::ptpip

#endif  // HDRSTEREO_HARDWARE_SIM_PTPIP_PACKETS_H_
