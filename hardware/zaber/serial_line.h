// SPDX-License-Identifier: GPL-3.0-or-later
//
// A byte line to a serial device, 8N1 without flow control. Real ports
// (USB adapters, /dev/ttyS*) go through libserialport. libserialport looks
// ports up in sysfs, where pseudo-terminals have no entry, so a pty (the
// simulated controller, socat bridges) is driven with termios directly; the
// Zaber driver above is the same for both.
#ifndef HDRSTEREO_HARDWARE_ZABER_SERIAL_LINE_H_
#define HDRSTEREO_HARDWARE_ZABER_SERIAL_LINE_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

namespace hdrstereo::zaber {

class SerialLine {
 public:
  virtual ~SerialLine() = default;
  // Writes everything or fails (DEADLINE_EXCEEDED after `timeout`).
  virtual absl::Status Write(absl::string_view data,
                             absl::Duration timeout) = 0;
  // Waits up to `timeout` for bytes and returns what arrived (empty on
  // timeout).
  virtual absl::StatusOr<std::string> Read(absl::Duration timeout) = 0;
  // Drops unread input.
  virtual void DiscardInput() = 0;
};

// UNAVAILABLE naming the port when it cannot be opened or configured.
absl::StatusOr<std::unique_ptr<SerialLine>> OpenSerialLine(
    const std::string& port, int baud_rate);

}  // namespace hdrstereo::zaber

#endif  // HDRSTEREO_HARDWARE_ZABER_SERIAL_LINE_H_
