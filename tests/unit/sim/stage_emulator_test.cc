// SPDX-License-Identifier: GPL-3.0-or-later
//
// Drives the emulated Zaber controller through its pseudo-terminal with
// plain termios, the way a serial-port driver does.
#include "hardware/sim/stage_emulator.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "hardware/sim/sim_world.h"
#include "tests/unit/sim/test_scenes.h"

namespace hdrstereo::sim {
namespace {

// How long to wait for a reply that should come; generous for loaded
// machines (the emulator polls every 5 ms).
constexpr int kReplyTimeoutMs = 5000;
// How long to wait before deciding that no reply is coming.
constexpr int kSilenceMs = 300;

class SerialClient {
 public:
  explicit SerialClient(const std::string& path) {
    fd_ = open(path.c_str(), O_RDWR | O_NOCTTY);
    EXPECT_GE(fd_, 0) << path;
    termios tio;
    EXPECT_EQ(tcgetattr(fd_, &tio), 0);
    cfmakeraw(&tio);
    cfsetispeed(&tio, B115200);
    cfsetospeed(&tio, B115200);
    tio.c_cflag |= CLOCAL | CREAD;
    EXPECT_EQ(tcsetattr(fd_, TCSANOW, &tio), 0);
  }
  ~SerialClient() {
    if (fd_ >= 0) close(fd_);
  }

  void Send(const std::string& command) {
    const std::string line = command + "\n";
    ASSERT_EQ(write(fd_, line.data(), line.size()),
              static_cast<ssize_t>(line.size()));
  }

  // One reply line without "\r\n", or nullopt after `timeout_ms`.
  std::optional<std::string> ReadLine(int timeout_ms) {
    std::string line;
    while (true) {
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, timeout_ms) <= 0) return std::nullopt;
      char c;
      if (read(fd_, &c, 1) != 1) return std::nullopt;
      if (c == '\n') break;
      line.push_back(c);
    }
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return line;
  }

  std::string Query(const std::string& command) {
    Send(command);
    std::optional<std::string> reply = ReadLine(kReplyTimeoutMs);
    EXPECT_TRUE(reply.has_value()) << "no reply to " << command;
    return reply.value_or("");
  }

 private:
  int fd_ = -1;
};

struct Reply {
  std::string device, axis, flag, status, warning, data;
};

Reply Parse(const std::string& line) {
  std::vector<std::string> f = absl::StrSplit(line, absl::MaxSplits(' ', 5));
  EXPECT_EQ(f.size(), 6u) << line;
  f.resize(6);
  return {f[0], f[1], f[2], f[3], f[4], f[5]};
}

std::unique_ptr<StageEmulator> StartOrDie(const StageEmulatorOptions& options,
                                          SimWorld* world = nullptr) {
  absl::StatusOr<std::unique_ptr<StageEmulator>> e =
      StageEmulator::Start(options, world);
  EXPECT_TRUE(e.ok()) << e.status();
  return e.ok() ? *std::move(e) : nullptr;
}

// Polls "/1 1 get pos" until IDLE (at most `max_polls` times).
Reply WaitIdle(SerialClient& client, int max_polls = 1000) {
  Reply r;
  for (int i = 0; i < max_polls; ++i) {
    r = Parse(client.Query("/1 1 get pos"));
    if (r.status == "IDLE") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return r;
}

TEST(StageEmulatorTest, HomeMoveAndGetPositionRoundTrip) {
  SimWorld world(testing::SmallBundledScene("lab-lamp"));
  StageEmulatorOptions options = StageEmulatorOptions::FromScene(world.scene());
  options.start_mm = 40;
  auto stage = StartOrDie(options, &world);
  ASSERT_NE(stage, nullptr);
  SerialClient client(stage->device_path());

  // Not homed yet: the WR warning, position where it was left.
  Reply r = Parse(client.Query("/1 1 get pos"));
  EXPECT_EQ(r.device, "@01");
  EXPECT_EQ(r.axis, "1");
  EXPECT_EQ(r.flag, "OK");
  EXPECT_EQ(r.status, "IDLE");
  EXPECT_EQ(r.warning, "WR");
  EXPECT_EQ(r.data, absl::StrCat(stage->MicrostepsForMm(40)));

  r = Parse(client.Query("/1 1 home"));
  EXPECT_EQ(r.flag, "OK");
  EXPECT_EQ(r.status, "BUSY");
  r = WaitIdle(client);
  EXPECT_EQ(r.status, "IDLE");
  EXPECT_EQ(r.warning, "--");
  EXPECT_EQ(r.data, "0");
  EXPECT_TRUE(stage->Homed());

  const int64_t target = stage->MicrostepsForMm(75);
  r = Parse(client.Query(absl::StrCat("/1 1 move abs ", target)));
  EXPECT_EQ(r.flag, "OK");
  EXPECT_EQ(r.status, "BUSY");
  EXPECT_EQ(r.data, "0");
  r = WaitIdle(client);
  EXPECT_EQ(r.data, absl::StrCat(target));
  EXPECT_NEAR(world.StagePosition(), 75.0, 1e-4);  // mirrored into the world

  r = Parse(client.Query("/1 1 move rel -20000"));
  EXPECT_EQ(r.flag, "OK");
  r = WaitIdle(client);
  EXPECT_EQ(r.data, absl::StrCat(target - 20000));

  r = Parse(client.Query("/1 1 move max"));
  r = WaitIdle(client);
  EXPECT_EQ(r.data, absl::StrCat(stage->MicrostepsForMm(150)));

  // Address only, and the all-devices address.
  r = Parse(client.Query("/1"));
  EXPECT_EQ(r.axis, "0");
  EXPECT_EQ(r.flag, "OK");
  r = Parse(client.Query("/get pos"));
  EXPECT_EQ(r.data, absl::StrCat(stage->MicrostepsForMm(150)));
}

TEST(StageEmulatorTest, RejectsLikeARealDevice) {
  StageEmulatorOptions options;  // 150 mm travel
  auto stage = StartOrDie(options);
  ASSERT_NE(stage, nullptr);
  SerialClient client(stage->device_path());
  const int64_t max = stage->MicrostepsForMm(150);

  Reply r = Parse(client.Query("/1 1 get limit.max"));
  EXPECT_EQ(r.data, absl::StrCat(max));
  for (const std::string& bad :
       {absl::StrCat("/1 1 move abs ", max + 1),
        std::string("/1 1 move abs -5"), std::string("/1 1 move rel -1"),
        std::string("/1 1 move abs 1.5mm"), std::string("/1 1 get colour")}) {
    r = Parse(client.Query(bad));
    EXPECT_EQ(r.flag, "RJ") << bad;
    EXPECT_EQ(r.status, "IDLE") << bad;
    EXPECT_EQ(r.data, "BADDATA") << bad;
  }
  r = Parse(client.Query("/1 1 fly away"));
  EXPECT_EQ(r.flag, "RJ");
  EXPECT_EQ(r.data, "BADCOMMAND");
  r = Parse(client.Query("/1 3 get pos"));
  EXPECT_EQ(r.flag, "RJ");
  EXPECT_EQ(r.data, "BADAXIS");
  // Another device number: no reply at all; the next command still works.
  client.Send("/2 1 get pos");
  EXPECT_FALSE(client.ReadLine(kSilenceMs).has_value());
  r = Parse(client.Query("/1 1 get pos"));
  EXPECT_EQ(r.data, "0");  // never moved
  EXPECT_EQ(stage->PositionMm(), 0.0);

  // 20 mm/s = 419947.5 microsteps/s; Zaber speed data = that * 1.6384.
  r = Parse(client.Query("/1 1 get maxspeed"));
  EXPECT_EQ(r.data,
            absl::StrCat(std::llround(20.0 * 1000 / 0.047625 * 1.6384)));
}

TEST(StageEmulatorTest, MovesAtTheModelledSpeedAndStops) {
  StageEmulatorOptions options;
  options.timing.scale = 1.0;  // real time
  options.timing.stage_speed_mm_s = 10;
  options.timing.stage_accel_mm_s2 = 1000;
  auto stage = StartOrDie(options);
  ASSERT_NE(stage, nullptr);
  SerialClient client(stage->device_path());
  const int64_t max = stage->MicrostepsForMm(150);
  // 150 mm at 10 mm/s takes 15 s: right after the command it is moving.
  Reply r = Parse(client.Query(absl::StrCat("/1 1 move abs ", max)));
  EXPECT_EQ(r.status, "BUSY");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  r = Parse(client.Query("/1 1 get pos"));
  EXPECT_EQ(r.status, "BUSY");
  int64_t pos = 0;
  ASSERT_TRUE(absl::SimpleAtoi(r.data, &pos)) << r.data;
  // At least 200 ms have passed: >= 0.5 * a * t_a^2 + v * (0.2 - t_a)
  // = 0.05 + 1.9 mm.
  EXPECT_GE(pos, stage->MicrostepsForMm(1.9));
  EXPECT_LT(pos, max);
  r = Parse(client.Query("/1 1 stop"));
  EXPECT_EQ(r.flag, "OK");
  EXPECT_EQ(r.status, "IDLE");
  const double stopped_at = stage->PositionMm();
  EXPECT_LT(stopped_at, 150.0);
  r = Parse(client.Query("/1 1 get pos"));
  EXPECT_EQ(r.status, "IDLE");
  EXPECT_NEAR(stage->PositionMm(), stopped_at, 1e-9);
}

TEST(StageEmulatorTest, StallFaultStaysBusyUntilStopped) {
  StageEmulatorOptions options;
  options.faults.stall.calls = {1};
  auto stage = StartOrDie(options);
  ASSERT_NE(stage, nullptr);
  SerialClient client(stage->device_path());
  const int64_t target = stage->MicrostepsForMm(100);
  Reply r = Parse(client.Query(absl::StrCat("/1 1 move abs ", target)));
  EXPECT_EQ(r.status, "BUSY");
  for (int i = 0; i < 20; ++i) {
    r = Parse(client.Query("/1 1 get pos"));
    ASSERT_EQ(r.status, "BUSY") << "poll " << i;
    EXPECT_EQ(r.data, absl::StrCat(target / 2));  // stuck halfway
  }
  r = Parse(client.Query("/1 1 stop"));
  EXPECT_EQ(r.status, "IDLE");
  r = Parse(client.Query("/1 1 get pos"));
  EXPECT_EQ(r.status, "IDLE");
  // The next move (call 24) is not stalled.
  r = Parse(client.Query(absl::StrCat("/1 1 move abs ", target)));
  r = WaitIdle(client);
  EXPECT_EQ(r.data, absl::StrCat(target));
}

TEST(StageEmulatorTest, GarbledAndSilentFaults) {
  StageEmulatorOptions options;
  options.faults.garbled.calls = {2};
  options.faults.silent.calls = {3};
  auto stage = StartOrDie(options);
  ASSERT_NE(stage, nullptr);
  SerialClient client(stage->device_path());
  EXPECT_EQ(Parse(client.Query("/1 1 get pos")).device, "@01");  // 1
  const std::string garbled = client.Query("/1 1 get pos");      // 2
  EXPECT_NE(garbled.substr(0, 1), "@") << garbled;
  EXPECT_NE(garbled, "@01 1 OK IDLE WR 0");
  client.Send("/1 1 get pos");  // 3: silent
  EXPECT_FALSE(client.ReadLine(kSilenceMs).has_value());
  const Reply r = Parse(client.Query("/1 1 get pos"));  // 4
  EXPECT_EQ(r.device, "@01");
  EXPECT_EQ(r.data, "0");
}

// A warning window shows its flag on the replies of `lasts` commands from
// the Nth (and in `warnings`, where it cannot be cleared), then goes.
TEST(StageEmulatorTest, WarningWindowComesAndGoesByCommands) {
  StageEmulatorOptions options;
  options.faults.warning_window = {.begins = {.calls = {2}}, .lasts = 2};
  options.faults.warning_window_flag = "WH";
  auto stage = StartOrDie(options);
  ASSERT_NE(stage, nullptr);
  SerialClient client(stage->device_path());
  EXPECT_EQ(Parse(client.Query("/1 1 get pos")).warning, "WR");            // 1
  EXPECT_EQ(Parse(client.Query("/1 1 get pos")).warning, "WH");            // 2
  EXPECT_EQ(Parse(client.Query("/1 1 warnings clear")).data, "02 WH WR");  // 3
  EXPECT_EQ(Parse(client.Query("/1 1 get pos")).warning, "WR");            // 4
  EXPECT_EQ(Parse(client.Query("/1 1 warnings")).data, "01 WR");           // 5
}

TEST(StageEmulatorTest, WarningFlagFaultIsReportedAndClearable) {
  StageEmulatorOptions options;
  options.faults.warning_flag = "FS";
  auto stage = StartOrDie(options);
  ASSERT_NE(stage, nullptr);
  SerialClient client(stage->device_path());
  EXPECT_EQ(Parse(client.Query("/1 1 get pos")).warning, "FS");
  Reply r = Parse(client.Query("/1 1 warnings clear"));
  EXPECT_EQ(r.data, "02 FS WR");
  EXPECT_EQ(Parse(client.Query("/1 1 get pos")).warning, "WR");
}

}  // namespace
}  // namespace hdrstereo::sim
