// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Zaber ASCII protocol, as text: commands "/1 1 move abs 1000\n" and
// replies "@01 1 OK IDLE -- 0". Pure functions, so that the driver's parsing
// is tested without a device.
#ifndef HDRSTEREO_HARDWARE_ZABER_PROTOCOL_H_
#define HDRSTEREO_HARDWARE_ZABER_PROTOCOL_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::zaber {

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
// that are not a well-formed reply ("@..."), e.g. garbled bytes.
absl::StatusOr<Reply> ParseReply(absl::string_view line);

// Splits the data of a `warnings` reply ("02 FZ WR") into flags.
std::vector<std::string> ParseWarningFlags(absl::string_view data);

// What a warning flag means, for people (e.g. "FZ": "not homed").
std::string DescribeWarning(absl::string_view flag);

// Whether a flag is a fault (F*) rather than a notice (N*) or warning (W*).
bool IsFault(absl::string_view flag);

}  // namespace hdrstereo::zaber

#endif  // HDRSTEREO_HARDWARE_ZABER_PROTOCOL_H_
