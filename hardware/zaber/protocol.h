// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Zaber ASCII protocol, as text: commands "/1 1 move abs 1000\n" and
// replies "@01 1 OK IDLE -- 0". Pure functions, so that the driver's parsing
// is tested without a device.
#ifndef HDRSTEREO_HARDWARE_ZABER_PROTOCOL_H_
#define HDRSTEREO_HARDWARE_ZABER_PROTOCOL_H_

#include <cstddef>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::zaber {

// Limits on what a reply may hold. A Zaber reply is well under 100 bytes
// ("@01 1 OK IDLE -- 0"; a packet holds 80 characters by default,
// comm.packet.size.max); device addresses are 1-99 and axes 0-9 (0: the
// device as a whole).
inline constexpr size_t kMaxReplyBytes = 1024;
inline constexpr int kMaxDevice = 99;
inline constexpr int kMaxAxis = 9;
// The two-digit count of a `warnings` reply.
inline constexpr size_t kMaxWarningFlags = 99;

// "/<device> <axis> <command>\n"; an empty command asks for the status.
std::string FormatCommand(int device, int axis, absl::string_view command);

struct Reply {
  int device = 0;
  int axis = 0;
  bool rejected = false;  // "RJ" instead of "OK"
  bool busy = false;      // "BUSY" instead of "IDLE"
  std::string warning;    // highest-priority warning flag, "" for "--"
  std::string data;       // the rest: a value, or the rejection reason
};

// Parses one reply line (trailing "\r\n" allowed). INVALID_ARGUMENT for lines
// that are not a well-formed reply ("@..."), e.g. garbled bytes, for a line
// longer than kMaxReplyBytes and for a device or axis number out of range;
// the message quotes the line bounded (QuoteInput).
absl::StatusOr<Reply> ParseReply(absl::string_view line);

// Splits the data of a `warnings` reply ("02 FZ WR") into flags: the
// two-character fields after the count, at most kMaxWarningFlags of them.
std::vector<std::string> ParseWarningFlags(absl::string_view data);

// What a warning flag means, for people (e.g. "FZ": "not homed").
std::string DescribeWarning(absl::string_view flag);

// Whether a flag is a fault (F*) rather than a notice (N*) or warning (W*).
bool IsFault(absl::string_view flag);

}  // namespace hdrstereo::zaber

#endif  // HDRSTEREO_HARDWARE_ZABER_PROTOCOL_H_
