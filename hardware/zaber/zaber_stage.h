// SPDX-License-Identifier: GPL-3.0-or-later
//
// Stage over a Zaber controller speaking the ASCII protocol on a serial port
// (see serial_line.h). In simulation the port is the emulator's
// pseudo-terminal, so this same driver runs in every integration test.
#ifndef HDRSTEREO_HARDWARE_ZABER_ZABER_STAGE_H_
#define HDRSTEREO_HARDWARE_ZABER_ZABER_STAGE_H_

#include <memory>
#include <mutex>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "hardware/stage.h"
#include "hardware/zaber/protocol.h"
#include "hardware/zaber/serial_line.h"

namespace hdrstereo::zaber {

struct ZaberOptions {
  std::string port;  // e.g. /dev/ttyUSB0, /dev/serial/by-id/..., a pty
  int baud_rate = 115200;
  int device = 1;
  int axis = 1;
  // Distance of one microstep; X-LSM150A: 0.047625 um (default resolution).
  double microstep_um = 0.047625;
  double travel_mm = 150;
  // How long to wait for each reply line.
  absl::Duration reply_timeout = absl::Milliseconds(500);
  absl::Duration poll_interval = absl::Milliseconds(20);
  // A move may take this factor times its ideal duration, plus the margin.
  double move_time_factor = 1.5;
  absl::Duration move_time_margin = absl::Seconds(2);
  // Resends of a command whose reply was missing or garbled. Only absolute,
  // idempotent commands are sent, so a resend is always safe.
  int retries = 2;
};

class ZaberStage final : public hardware::Stage {
 public:
  // Opens the port (8N1, no flow control) and reads the maximum speed.
  // UNAVAILABLE when the port cannot be opened or the device does not answer.
  static absl::StatusOr<std::unique_ptr<ZaberStage>> Open(
      const ZaberOptions& options);

  absl::Status Home() override;
  absl::Status MoveTo(double position_mm) override;
  absl::StatusOr<hardware::StageState> State() override;
  absl::Status Stop() override;
  double travel_mm() const override { return options_.travel_mm; }

  double speed_mm_per_s() const { return speed_mm_per_s_; }
  int64_t ToMicrosteps(double mm) const;
  double ToMillimetres(int64_t microsteps) const;

 private:
  ZaberStage(const ZaberOptions& options, std::unique_ptr<SerialLine> line)
      : options_(options), line_(std::move(line)) {}

  // Sends one command and returns its reply; resends on a missing or garbled
  // reply; a rejection (RJ) becomes an error naming the command and reason.
  absl::StatusOr<Reply> Command(absl::string_view command);
  absl::StatusOr<Reply> CommandOnce(absl::string_view command);
  absl::StatusOr<std::string> ReadLine(absl::Time deadline);
  // Polls until IDLE; fails on a fault flag, an interruption or `timeout`.
  absl::Status WaitUntilIdle(absl::Duration timeout, absl::string_view what,
                             double target_mm);

  const ZaberOptions options_;
  std::unique_ptr<SerialLine> line_;
  std::mutex mutex_;     // one command/reply exchange at a time
  std::string pending_;  // bytes read past the last line
  double speed_mm_per_s_ = 0;
};

}  // namespace hdrstereo::zaber

#endif  // HDRSTEREO_HARDWARE_ZABER_ZABER_STAGE_H_
