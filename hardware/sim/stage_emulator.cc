// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/stage_emulator.h"

#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "hardware/sim/noise.h"
#include "hardware/sim/sim_world.h"

namespace hdrstereo::sim {
namespace {

bool ParseInt(const std::string& s, int64_t* out) {
  if (s.empty()) return false;
  const char* begin = s.data();
  if (*begin == '+') ++begin;
  auto [ptr, ec] = std::from_chars(begin, s.data() + s.size(), *out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

absl::Status Errno(const std::string& what) {
  return absl::InternalError(absl::StrCat(what, ": ", std::strerror(errno)));
}

}  // namespace

StageEmulatorOptions StageEmulatorOptions::FromScene(const Scene& scene) {
  StageEmulatorOptions o;
  o.travel_mm = scene.rig.travel_mm;
  o.timing = scene.timing;
  o.faults = scene.stage_faults;
  o.seed = scene.seed;
  return o;
}

StageEmulator::StageEmulator(const StageEmulatorOptions& options,
                             SimWorld* world)
    : options_(options),
      world_(world),
      warning_window_(options.faults.warning_window, options.seed, 14) {
  max_position_ = MicrostepsForMm(options_.travel_mm);
  position_ =
      std::clamp<int64_t>(MicrostepsForMm(options_.start_mm), 0, max_position_);
}

absl::StatusOr<std::unique_ptr<StageEmulator>> StageEmulator::Start(
    const StageEmulatorOptions& options, SimWorld* world) {
  if (!(options.microstep_um > 0) || !(options.travel_mm > 0) ||
      !(options.timing.stage_speed_mm_s > 0) ||
      !(options.timing.stage_accel_mm_s2 > 0)) {
    return absl::InvalidArgumentError(
        "stage emulator needs microstep_um, travel_mm, speed and acceleration "
        "> 0");
  }
  std::unique_ptr<StageEmulator> e(new StageEmulator(options, world));
  e->master_fd_ = posix_openpt(O_RDWR | O_NOCTTY);
  if (e->master_fd_ < 0) return Errno("posix_openpt");
  if (grantpt(e->master_fd_) != 0) return Errno("grantpt");
  if (unlockpt(e->master_fd_) != 0) return Errno("unlockpt");
  char name[128];
  if (ptsname_r(e->master_fd_, name, sizeof(name)) != 0) {
    return Errno("ptsname_r");
  }
  e->device_path_ = name;
  e->slave_fd_ = open(name, O_RDWR | O_NOCTTY);
  if (e->slave_fd_ < 0) return Errno(absl::StrCat("open ", name));
  termios tio;
  if (tcgetattr(e->slave_fd_, &tio) != 0) return Errno("tcgetattr");
  cfmakeraw(&tio);
  cfsetispeed(&tio, B115200);
  cfsetospeed(&tio, B115200);
  if (tcsetattr(e->slave_fd_, TCSANOW, &tio) != 0) return Errno("tcsetattr");
  const int flags = fcntl(e->master_fd_, F_GETFL);
  if (flags < 0 || fcntl(e->master_fd_, F_SETFL, flags | O_NONBLOCK) != 0) {
    return Errno("fcntl O_NONBLOCK");
  }
  if (world != nullptr) world->SetStagePosition(e->PositionMm());
  e->thread_ = std::thread([raw = e.get()] { raw->Run(); });
  return e;
}

StageEmulator::~StageEmulator() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (slave_fd_ >= 0) close(slave_fd_);
  if (master_fd_ >= 0) close(master_fd_);
}

int64_t StageEmulator::MicrostepsForMm(double mm) const {
  return static_cast<int64_t>(
      std::llround(mm * 1000.0 / options_.microstep_um));
}

double StageEmulator::MmForMicrosteps(int64_t steps) const {
  return static_cast<double>(steps) * options_.microstep_um / 1000.0;
}

double StageEmulator::PositionMm() const {
  std::lock_guard<std::mutex> lock(mu_);
  return MmForMicrosteps(position_);
}

bool StageEmulator::Busy() const {
  std::lock_guard<std::mutex> lock(mu_);
  return moving_;
}

bool StageEmulator::Homed() const {
  std::lock_guard<std::mutex> lock(mu_);
  return homed_;
}

void StageEmulator::Run() {
  char buf[512];
  while (!stop_) {
    pollfd p{master_fd_, POLLIN, 0};
    const int r = poll(&p, 1, 5);
    if (r > 0 && (p.revents & POLLIN)) {
      const ssize_t n = read(master_fd_, buf, sizeof(buf));
      if (n > 0) {
        for (ssize_t i = 0; i < n; ++i) {
          const char c = buf[i];
          if (c == '\n' || c == '\r') {
            if (!pending_.empty()) {
              std::string line;
              line.swap(pending_);
              HandleLine(line);
            }
          } else if (pending_.size() < 1024) {
            pending_.push_back(c);
          }
        }
      }
    } else if (r > 0) {
      usleep(5000);  // hang-up or error: no client; wait for one
    }
    std::lock_guard<std::mutex> lock(mu_);
    UpdateLocked(std::chrono::steady_clock::now());
  }
}

void StageEmulator::UpdateLocked(std::chrono::steady_clock::time_point now) {
  if (moving_) {
    const double distance_mm = MmForMicrosteps(std::abs(move_to_ - move_from_));
    const double scale = options_.timing.scale;
    double progress_mm = distance_mm;
    bool done = true;
    if (scale > 0) {
      const double t =
          std::chrono::duration<double>(now - move_start_).count() / scale;
      progress_mm = options_.timing.MoveProgressMm(distance_mm, t);
      done = t >= options_.timing.MoveSeconds(distance_mm);
    }
    if (stalled_) {  // stuck halfway, BUSY until stopped
      progress_mm = std::min(progress_mm, distance_mm / 2);
      done = false;
    }
    const int64_t steps = std::min<int64_t>(MicrostepsForMm(progress_mm),
                                            std::abs(move_to_ - move_from_));
    position_ = move_from_ + (move_to_ >= move_from_ ? steps : -steps);
    if (done) {
      position_ = move_to_;
      moving_ = false;
      if (homing_) homed_ = true;
      homing_ = false;
    }
  }
  if (world_ != nullptr) world_->SetStagePosition(MmForMicrosteps(position_));
}

void StageEmulator::StartMoveLocked(int64_t target, bool homing, bool stall) {
  UpdateLocked(std::chrono::steady_clock::now());
  move_from_ = position_;
  move_to_ = target;
  move_start_ = std::chrono::steady_clock::now();
  moving_ = true;
  homing_ = homing;
  stalled_ = stall;
}

std::string StageEmulator::FlagLocked() const {
  if (warning_window_holds_) return options_.faults.warning_window_flag;
  if (options_.faults.warning_flag != "--") return options_.faults.warning_flag;
  if (!homed_) return "WR";
  return "--";
}

void StageEmulator::HandleLine(const std::string& raw_line) {
  std::string line = raw_line;
  // Ignore anything before the start-of-command character, like the device.
  const size_t slash = line.find('/');
  if (slash == std::string::npos) return;
  line = line.substr(slash + 1);
  // Drop an optional ":XX" checksum.
  if (const size_t colon = line.find(':'); colon != std::string::npos) {
    line = line.substr(0, colon);
  }
  std::vector<std::string> tokens =
      absl::StrSplit(line, ' ', absl::SkipWhitespace());
  size_t i = 0;
  int64_t device = 0, axis = 0;
  if (i < tokens.size() && ParseInt(tokens[i], &device)) ++i;
  if (i < tokens.size() && ParseInt(tokens[i], &axis)) ++i;
  if (device != 0 && device != options_.device_number) return;  // not us
  const int64_t n = ++commands_;
  const StageFaults& faults = options_.faults;
  if (FaultFires(faults.silent, n, options_.seed, 11)) return;
  const bool garble = FaultFires(faults.garbled, n, options_.seed, 12);

  std::vector<std::string> cmd(tokens.begin() + i, tokens.end());
  std::string reply_flag = "OK", data = "0";
  std::string warning_flag;
  {
    std::lock_guard<std::mutex> lock(mu_);
    warning_window_holds_ = warning_window_.Call();
    UpdateLocked(std::chrono::steady_clock::now());
    warning_flag = FlagLocked();
    auto reject = [&](const char* why) {
      reply_flag = "RJ";
      data = why;
    };
    if (axis < 0 || axis > 1) {
      reject("BADAXIS");
    } else if (cmd.empty()) {
      // Just an address: status only.
    } else if (cmd[0] == "home" && cmd.size() == 1) {
      StartMoveLocked(0, /*homing=*/true,
                      FaultFires(faults.stall, n, options_.seed, 13));
    } else if (cmd[0] == "move") {
      int64_t value = 0;
      int64_t target = -1;
      if (cmd.size() == 2 && cmd[1] == "min") {
        target = 0;
      } else if (cmd.size() == 2 && cmd[1] == "max") {
        target = max_position_;
      } else if (cmd.size() == 3 && (cmd[1] == "abs" || cmd[1] == "rel") &&
                 ParseInt(cmd[2], &value)) {
        target = cmd[1] == "abs" ? value : position_ + value;
      } else if (cmd.size() >= 2 && (cmd[1] == "abs" || cmd[1] == "rel" ||
                                     cmd[1] == "min" || cmd[1] == "max")) {
        reject("BADDATA");
      } else {
        reject("BADCOMMAND");
      }
      if (reply_flag == "OK") {
        if (target < 0 || target > max_position_) {
          reject("BADDATA");
        } else {
          StartMoveLocked(target, /*homing=*/false,
                          FaultFires(faults.stall, n, options_.seed, 13));
        }
      }
    } else if (cmd[0] == "stop" && cmd.size() == 1) {
      moving_ = false;
      homing_ = false;
      stalled_ = false;
    } else if (cmd[0] == "get" && cmd.size() == 2) {
      if (cmd[1] == "pos") {
        data = absl::StrCat(position_);
      } else if (cmd[1] == "maxspeed") {
        const double steps_per_s =
            options_.timing.stage_speed_mm_s * 1000.0 / options_.microstep_um;
        data = absl::StrCat(std::llround(steps_per_s * 1.6384));
      } else if (cmd[1] == "limit.max") {
        data = absl::StrCat(max_position_);
      } else if (cmd[1] == "limit.min") {
        data = "0";
      } else if (cmd[1] == "system.serial") {
        data = "12345";
      } else {
        reject("BADDATA");
      }
    } else if (cmd[0] == "warnings" &&
               (cmd.size() == 1 || (cmd.size() == 2 && cmd[1] == "clear"))) {
      std::vector<std::string> flags;
      if (warning_window_holds_) {
        flags.push_back(options_.faults.warning_window_flag);
      }
      if (options_.faults.warning_flag != "--") {
        flags.push_back(options_.faults.warning_flag);
      }
      if (!homed_) flags.push_back("WR");
      data = absl::StrFormat("%02d", static_cast<int>(flags.size()));
      for (const std::string& f : flags) absl::StrAppend(&data, " ", f);
      if (cmd.size() == 2) options_.faults.warning_flag = "--";  // clearable
    } else {
      reject("BADCOMMAND");
    }
    if (reply_flag == "OK") warning_flag = FlagLocked();
  }
  const std::string status = Busy() ? "BUSY" : "IDLE";
  std::string reply =
      absl::StrFormat("@%02d %d %s %s %s %s", options_.device_number, axis,
                      reply_flag, status, warning_flag, data);
  if (garble) {
    uint64_t h = HashCombine(options_.seed, 5000 + static_cast<uint64_t>(n));
    static constexpr char kJunk[] = "#%&*?~^$";
    for (size_t k = 0; k < reply.size(); ++k) {
      h = SplitMix64(h);
      if (k == 0 || h % 3 == 0) reply[k] = kJunk[(h >> 8) % 8];
    }
  }
  Reply(reply + "\r\n");
}

void StageEmulator::Reply(const std::string& text) {
  size_t written = 0;
  int attempts = 0;
  while (written < text.size() && attempts++ < 100) {
    const ssize_t n =
        write(master_fd_, text.data() + written, text.size() - written);
    if (n > 0) {
      written += static_cast<size_t>(n);
    } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
      return;  // nobody listening
    } else {
      usleep(1000);
    }
  }
}

}  // namespace hdrstereo::sim
