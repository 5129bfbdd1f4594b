// SPDX-License-Identifier: GPL-3.0-or-later
//
// A Zaber ASCII-protocol linear stage controller emulated on a
// pseudo-terminal. Open device_path() like a serial port (any baud rate,
// 8N1, raw) and talk to it like to an X-LSQ150 on address 1:
//
//   /1 1 home              @01 1 OK BUSY WR 0     (moves to 0, then IDLE)
//   /1 1 move abs 1049869  @01 1 OK BUSY -- 0
//   /1 1 move rel -20000   @01 1 OK BUSY -- 0
//   /1 1 move min | max    @01 1 OK BUSY -- 0
//   /1 1 get pos           @01 1 OK IDLE -- 1049869
//   /1 1 get maxspeed      @01 1 OK IDLE -- 687931   (Zaber units, see below)
//   /1 1 get limit.max     @01 1 OK IDLE -- 3149606
//   /1 1 stop              @01 1 OK IDLE -- 0        (stops at once)
//   /1 1 warnings [clear]  @01 1 OK IDLE WR 01 WR    (count, then flags)
//   /1                     @01 0 OK IDLE -- 0
//
// Replies end in "\r\n". Rejections look like a real device's:
// "@01 1 RJ IDLE -- BADDATA" (out of travel, not a number),
// "... BADCOMMAND" (unknown command), "... BADAXIS" (axis other than 0/1).
// Commands for other device numbers get no reply. The warning flag is "WR"
// (no reference position) until the first home completes, or the configured
// fault flag (e.g. "FS") when set, or the warning window's flag (e.g. "WH")
// on the commands where that window holds.
//
// Units: positions are microsteps of microstep_um (default 0.047625 um, an
// X-LSQ150B with 64 microsteps); speed data = microsteps/s * 1.6384.
// Motion follows TimingModel (speed, acceleration) in real time divided by
// timing.scale; with scale 0 a move completes immediately, but the reply to
// the move command itself still says BUSY (as on a real device).
//
// Driver note: libserialport 0.1.1 (Debian 12) refuses pseudo-terminals:
// sp_get_port_by_name("/dev/pts/N") fails with "Device not found" because it
// looks the port up in /sys/class/tty/. A driver that must talk to this
// emulator needs a plain POSIX termios path (open, cfmakeraw, tcsetattr,
// poll/read/write) for such device paths; tests/unit/sim/
// stage_emulator_test.cc has a minimal one (SerialClient).
#ifndef HDRSTEREO_HARDWARE_SIM_STAGE_EMULATOR_H_
#define HDRSTEREO_HARDWARE_SIM_STAGE_EMULATOR_H_

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"

namespace hdrstereo::sim {

struct StageEmulatorOptions {
  double microstep_um = 0.047625;
  double travel_mm = 150.0;
  double start_mm = 0.0;  // position at power-up (not homed)
  TimingModel timing;
  StageFaults faults;
  uint64_t seed = 1;
  int device_number = 1;

  // Travel, timing, faults and seed from a scene.
  static StageEmulatorOptions FromScene(const Scene& scene);
};

class StageEmulator {
 public:
  // Opens the pty and starts the emulator thread. With a `world`, the
  // stage position is mirrored into world->SetStagePosition() as it moves
  // (the world must outlive the emulator).
  static absl::StatusOr<std::unique_ptr<StageEmulator>> Start(
      const StageEmulatorOptions& options, SimWorld* world = nullptr);
  ~StageEmulator();  // stops the thread, closes the pty
  StageEmulator(const StageEmulator&) = delete;
  StageEmulator& operator=(const StageEmulator&) = delete;

  // The slave side, e.g. "/dev/pts/7", for the serial-port driver.
  const std::string& device_path() const { return device_path_; }

  double PositionMm() const;
  bool Busy() const;
  bool Homed() const;
  int64_t commands_received() const { return commands_.load(); }
  int64_t MicrostepsForMm(double mm) const;
  double MmForMicrosteps(int64_t steps) const;

 private:
  StageEmulator(const StageEmulatorOptions& options, SimWorld* world);
  void Run();
  void HandleLine(const std::string& line);
  void Reply(const std::string& text);
  // Motion state; mu_ held.
  void UpdateLocked(std::chrono::steady_clock::time_point now);
  void StartMoveLocked(int64_t target, bool homing, bool stall);
  std::string FlagLocked() const;

  StageEmulatorOptions options_;
  SimWorld* world_;
  int master_fd_ = -1;
  int slave_fd_ = -1;  // held open so the pty survives client reconnects
  std::string device_path_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> commands_{0};

  mutable std::mutex mu_;
  int64_t position_ = 0;  // microsteps
  int64_t max_position_ = 0;
  bool homed_ = false;
  bool moving_ = false;
  bool homing_ = false;
  bool stalled_ = false;
  FaultWindowState warning_window_;
  bool warning_window_holds_ = false;  // on the command being answered
  int64_t move_from_ = 0;
  int64_t move_to_ = 0;
  std::chrono::steady_clock::time_point move_start_;
  std::string pending_;  // bytes of an incomplete command line
};

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_STAGE_EMULATOR_H_
