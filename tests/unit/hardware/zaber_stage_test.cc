// SPDX-License-Identifier: GPL-3.0-or-later
//
// The real Zaber driver (ZaberStage over a termios SerialLine) against the
// emulated controller (sim::StageEmulator) through a real pseudo-terminal,
// with every injected stage fault. The emulator runs at timing scale 0, so a
// move completes at once; the modelled speed still sets the driver's move
// timeouts, which is why moves here are short. One test runs in modelled
// real time to see the driver poll through BUSY replies.
//
// Call numbers: the emulator counts commands addressed to it (1-based) and
// fires FaultTrigger::calls on those numbers. At scale 0 the driver's
// exchanges are deterministic:
//   Open       1 call   get maxspeed
//   Home       2 calls  home, status poll ("/1 1")
//   State      2 calls  get pos, warnings
//   MoveTo     4 calls  get pos, warnings, move abs N, status poll
// The tests check commands_received() before the call they target, so a
// change in these sequences fails loudly instead of hitting another command.
#include "hardware/zaber/zaber_stage.h"

#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "absl/time/time.h"
#include "hardware/sim/stage_emulator.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::zaber {
namespace {

using ::hdrstereo::testing::StatusIs;

using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::Not;

constexpr double kMicrostepUm = 0.047625;
constexpr double kMicrostepMm = kMicrostepUm / 1000.0;
// The per-reply wait: the emulator answers within ~5 ms, so 400 ms is ample
// even on a loaded machine (a late reply would add a resend and break the
// call counting below), and keeps the fault tests short.
constexpr absl::Duration kReplyTimeout = absl::Milliseconds(400);
constexpr absl::Duration kMoveMargin = absl::Milliseconds(400);

std::string Message(const absl::Status& status) {
  return std::string(status.message());
}

class ZaberStageTest : public ::testing::Test {
 protected:
  // Starts the emulator with `faults` (and `speed_mm_s`) and opens the
  // driver on its pty.
  void Start(const sim::StageFaults& faults = {}, double speed_mm_s = 20.0,
             double time_scale = 0, double start_mm = 10.0) {
    sim::StageEmulatorOptions options;
    options.microstep_um = kMicrostepUm;
    options.travel_mm = 150.0;
    options.start_mm = start_mm;
    options.timing.scale = time_scale;
    options.timing.stage_speed_mm_s = speed_mm_s;
    options.faults = faults;
    options.seed = seed_;
    absl::StatusOr<std::unique_ptr<sim::StageEmulator>> emulator =
        sim::StageEmulator::Start(options);
    ASSERT_TRUE(emulator.ok()) << emulator.status();
    emulator_ = *std::move(emulator);
    absl::StatusOr<std::unique_ptr<ZaberStage>> stage =
        ZaberStage::Open(Options());
    ASSERT_TRUE(stage.ok()) << stage.status();
    stage_ = *std::move(stage);
    ASSERT_EQ(emulator_->commands_received(), 1);  // get maxspeed
  }

  ZaberOptions Options() const {
    ZaberOptions options;
    options.port = emulator_->device_path();
    options.microstep_um = kMicrostepUm;
    options.travel_mm = 150.0;
    options.reply_timeout = kReplyTimeout;
    options.poll_interval = absl::Milliseconds(2);
    options.move_time_margin = kMoveMargin;
    options.retries = 2;
    return options;
  }

  uint64_t seed_ = 1;
  std::unique_ptr<sim::StageEmulator> emulator_;
  std::unique_ptr<ZaberStage> stage_;
};

sim::FaultTrigger OnCalls(std::initializer_list<int> calls) {
  sim::FaultTrigger trigger;
  trigger.calls = calls;
  return trigger;
}

sim::FaultTrigger Always() {
  sim::FaultTrigger trigger;
  trigger.probability = 1.0;
  return trigger;
}

TEST_F(ZaberStageTest, OpenReadsTheModelledMaximumSpeed) {
  for (double speed : {20.0, 7.5, 350.0}) {
    SCOPED_TRACE(speed);
    ASSERT_NO_FATAL_FAILURE(Start({}, speed));
    // maxspeed travels as round(microsteps/s * 1.6384): a relative error of
    // at most 1e-6 for these speeds.
    EXPECT_NEAR(stage_->speed_mm_per_s(), speed, speed * 1e-6);
    EXPECT_EQ(stage_->travel_mm(), 150.0);
    stage_.reset();
    emulator_.reset();
  }
}

TEST_F(ZaberStageTest, OpenFailsClearlyWithoutADevice) {
  ZaberOptions options;
  options.port = "/dev/pts/999999";
  absl::StatusOr<std::unique_ptr<ZaberStage>> stage = ZaberStage::Open(options);
  EXPECT_EQ(stage.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(Message(stage.status()), HasSubstr("/dev/pts/999999"));

  options.port = "/dev/ttyUSB-hdrstereo-does-not-exist";
  stage = ZaberStage::Open(options);
  EXPECT_EQ(stage.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(Message(stage.status()),
              HasSubstr("/dev/ttyUSB-hdrstereo-does-not-exist"));
}

TEST_F(ZaberStageTest, MillimetresAndMicrostepsConvertWithTheResolution) {
  ASSERT_NO_FATAL_FAILURE(Start());
  // 1 mm = 1000 / 0.047625 = 20997.375 microsteps.
  EXPECT_EQ(stage_->ToMicrosteps(1.0), 20997);
  EXPECT_EQ(stage_->ToMicrosteps(150.0), 3149606);  // the emulator's limit.max
  EXPECT_EQ(stage_->ToMicrosteps(0.0), 0);
  EXPECT_DOUBLE_EQ(stage_->ToMillimetres(20997), 20997 * kMicrostepMm);
  EXPECT_DOUBLE_EQ(stage_->ToMillimetres(-2), -2 * kMicrostepMm);
  for (double mm : {0.0, 0.01, 1.0, 42.5, 99.999, 150.0}) {
    EXPECT_EQ(stage_->ToMicrosteps(mm), emulator_->MicrostepsForMm(mm)) << mm;
    // Rounding to the nearest microstep: at most half a step off.
    EXPECT_LE(std::abs(stage_->ToMillimetres(stage_->ToMicrosteps(mm)) - mm),
              kMicrostepMm / 2 + 1e-12)
        << mm;
  }
  // Another resolution (a 0.1 um device) scales both ways.
  stage_.reset();  // one client on the pty at a time
  ZaberOptions options = Options();
  options.microstep_um = 0.1;
  absl::StatusOr<std::unique_ptr<ZaberStage>> coarse =
      ZaberStage::Open(options);
  ASSERT_TRUE(coarse.ok()) << coarse.status();
  EXPECT_EQ((*coarse)->ToMicrosteps(1.0), 10000);
  EXPECT_DOUBLE_EQ((*coarse)->ToMillimetres(12345), 1.2345);
}

TEST_F(ZaberStageTest, HomeThenMoveRoundTrips) {
  ASSERT_NO_FATAL_FAILURE(Start());
  absl::StatusOr<hardware::StageState> state = stage_->State();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_FALSE(state->homed);
  EXPECT_THAT(state->warning_flags, ElementsAre("WR"));
  EXPECT_NEAR(state->position_mm, 10.0, kMicrostepMm);
  EXPECT_FALSE(state->busy);

  ASSERT_TRUE(stage_->Home().ok());
  EXPECT_TRUE(emulator_->Homed());
  state = stage_->State();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_TRUE(state->homed);
  EXPECT_THAT(state->warning_flags, IsEmpty());
  EXPECT_EQ(state->position_mm, 0.0);

  for (double target : {42.5, 0.123456, 150.0, 0.0, 73.0001}) {
    SCOPED_TRACE(target);
    ASSERT_TRUE(stage_->MoveTo(target).ok());
    state = stage_->State();
    ASSERT_TRUE(state.ok()) << state.status();
    EXPECT_NEAR(state->position_mm, target, kMicrostepMm);
    EXPECT_NEAR(emulator_->PositionMm(), target, kMicrostepMm);
    EXPECT_FALSE(state->busy);
    EXPECT_TRUE(state->homed);
  }
}

TEST_F(ZaberStageTest, MovesWaitWhileTheStageIsBusy) {
  // In modelled real time (scale 1, 20 mm/s, 100 mm/s^2) a 2 mm move takes
  // 0.28 s, so the driver sees BUSY replies and must keep polling.
  ASSERT_NO_FATAL_FAILURE(
      Start({}, /*speed_mm_s=*/20.0, /*time_scale=*/1.0, /*start_mm=*/1.0));
  ASSERT_TRUE(stage_->Home().ok());
  EXPECT_EQ(emulator_->PositionMm(), 0.0);
  EXPECT_TRUE(emulator_->Homed());
  const int64_t before = emulator_->commands_received();
  ASSERT_TRUE(stage_->MoveTo(2.0).ok());
  EXPECT_FALSE(emulator_->Busy());
  EXPECT_NEAR(emulator_->PositionMm(), 2.0, kMicrostepMm);
  // get pos, warnings, move abs, then more than one status poll.
  EXPECT_GT(emulator_->commands_received() - before, 4);
}

TEST_F(ZaberStageTest, TargetsOutsideTheTravelAreRejectedWithoutMoving) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_TRUE(stage_->Home().ok());
  ASSERT_TRUE(stage_->MoveTo(20.0).ok());
  const int64_t commands = emulator_->commands_received();
  for (double target :
       {-0.001, 150.001, 200.0, -1e9, std::numeric_limits<double>::quiet_NaN(),
        std::numeric_limits<double>::infinity()}) {
    SCOPED_TRACE(target);
    absl::Status status = stage_->MoveTo(target);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << status;
    EXPECT_THAT(Message(status), HasSubstr("outside the travel [0, 150] mm"));
  }
  // Nothing was sent to the device, and it did not move.
  EXPECT_EQ(emulator_->commands_received(), commands);
  EXPECT_NEAR(emulator_->PositionMm(), 20.0, kMicrostepMm);
}

TEST_F(ZaberStageTest, SilentDeviceIsADeadlineNamingTheCommand) {
  // Call 2 is the "home" command; calls 2-4 are all its tries.
  sim::StageFaults faults;
  faults.silent = OnCalls({2, 3, 4});
  ASSERT_NO_FATAL_FAILURE(Start(faults));
  absl::Status status = stage_->Home();
  EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded) << status;
  EXPECT_THAT(Message(status), HasSubstr("did not answer \"home\""));
  EXPECT_THAT(Message(status), HasSubstr("3 tries"));
  EXPECT_FALSE(hardware::IsStalled(status));  // silent, not stalled
  EXPECT_EQ(emulator_->commands_received(), 4);
  // The device answers again afterwards and the driver recovers.
  EXPECT_TRUE(stage_->Home().ok());
  EXPECT_TRUE(emulator_->Homed());
}

TEST_F(ZaberStageTest, SilentStatusPollNamesWhatWasAsked) {
  // Home: "home" is call 2, its status polls are calls 3-5.
  sim::StageFaults faults;
  faults.silent = OnCalls({3, 4, 5});
  ASSERT_NO_FATAL_FAILURE(Start(faults));
  absl::Status status = stage_->Home();
  EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded) << status;
  EXPECT_THAT(Message(status), HasSubstr("did not answer"));
  // The poll is the bare address; an empty quote ("") would tell nobody
  // anything.
  EXPECT_THAT(Message(status), Not(HasSubstr("\"\"")));
  EXPECT_THAT(Message(status), HasSubstr("/1 1"));
}

TEST_F(ZaberStageTest, OneMissingReplyIsResent) {
  // Every command the driver sends is absolute, so one lost reply costs a
  // resend and nothing else.
  sim::StageFaults faults;
  faults.silent = OnCalls({2});  // the first "home"
  ASSERT_NO_FATAL_FAILURE(Start(faults));
  EXPECT_TRUE(stage_->Home().ok());
  EXPECT_TRUE(emulator_->Homed());
}

TEST_F(ZaberStageTest, SilentFromTheStartFailsOpen) {
  sim::StageEmulatorOptions options;
  options.faults.silent = Always();
  absl::StatusOr<std::unique_ptr<sim::StageEmulator>> emulator =
      sim::StageEmulator::Start(options);
  ASSERT_TRUE(emulator.ok()) << emulator.status();
  emulator_ = *std::move(emulator);
  absl::StatusOr<std::unique_ptr<ZaberStage>> stage =
      ZaberStage::Open(Options());
  EXPECT_EQ(stage.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(Message(stage.status()), HasSubstr("no Zaber device 1 axis 1"));
  EXPECT_THAT(Message(stage.status()),
              HasSubstr("did not answer \"get maxspeed\""));
  EXPECT_EQ(emulator_->commands_received(), 3);  // three tries, no more
}

TEST_F(ZaberStageTest, OneGarbledReplyIsResynchronised) {
  // Garble the reply to "home" (call 2), then to "get pos" of the State
  // after it (call 5): each costs one resend; values come through intact.
  sim::StageFaults faults;
  faults.garbled = OnCalls({2, 5});
  ASSERT_NO_FATAL_FAILURE(Start(faults));
  ASSERT_TRUE(stage_->Home().ok());
  ASSERT_EQ(emulator_->commands_received(), 4);  // home twice, one poll
  absl::StatusOr<hardware::StageState> state = stage_->State();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_EQ(emulator_->commands_received(), 7);  // get pos twice, warnings
  EXPECT_TRUE(state->homed);
  EXPECT_EQ(state->position_mm, 0.0);
  ASSERT_TRUE(stage_->MoveTo(12.5).ok());
  EXPECT_NEAR(emulator_->PositionMm(), 12.5, kMicrostepMm);
}

TEST_F(ZaberStageTest, PersistentGarbageIsDataLossNotATimeout) {
  // Every try of "home" (calls 2-4) gets a scrambled reply. The scrambling
  // depends on the seed and the call number; some scrambles start with '#',
  // the mark of a Zaber info message, so try several seeds: whatever the
  // bytes, the error must say garbage, not silence.
  for (uint64_t seed = 1; seed <= 24; ++seed) {
    SCOPED_TRACE(seed);
    seed_ = seed;
    sim::StageFaults faults;
    faults.garbled = OnCalls({2, 3, 4});
    ASSERT_NO_FATAL_FAILURE(Start(faults));
    absl::Status status = stage_->Home();
    EXPECT_EQ(status.code(), absl::StatusCode::kDataLoss) << status;
    EXPECT_THAT(Message(status), HasSubstr("answered \"home\" with garbage"));
    EXPECT_EQ(emulator_->commands_received(), 4);
    // The line is usable again once the device answers properly.
    EXPECT_TRUE(stage_->State().ok());
    stage_.reset();
    emulator_.reset();
  }
}

TEST_F(ZaberStageTest, StalledMoveTimesOutAndStops) {
  // MoveTo(1.0) after Open (1) and Home (2-3): get pos 4, warnings 5,
  // "move abs" 6 stalls (BUSY halfway until stopped).
  sim::StageFaults faults;
  faults.stall = OnCalls({6});
  ASSERT_NO_FATAL_FAILURE(Start(faults));
  ASSERT_TRUE(stage_->Home().ok());
  ASSERT_EQ(emulator_->commands_received(), 3);
  absl::Status status = stage_->MoveTo(1.0);
  EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded) << status;
  EXPECT_THAT(Message(status), HasSubstr("move to 1.000 mm did not finish"));
  EXPECT_THAT(Message(status), HasSubstr("stalled"));
  EXPECT_TRUE(hardware::IsStalled(status));
  // The driver sent "stop": the stage is idle where it got stuck, halfway.
  EXPECT_FALSE(emulator_->Busy());
  EXPECT_NEAR(emulator_->PositionMm(), 0.5, kMicrostepMm);
  EXPECT_THAT(Message(status), HasSubstr("stopped at 0.500 mm"));
  // And the next move works.
  EXPECT_TRUE(stage_->MoveTo(2.0).ok());
  EXPECT_NEAR(emulator_->PositionMm(), 2.0, kMicrostepMm);
}

TEST_F(ZaberStageTest, StalledHomingTimesOutAndStops) {
  // Homing may take the whole travel: at 20 mm/s that is 7.5 s x 1.5, so
  // this stage is modelled fast (1000 mm/s) to keep the timeout short.
  sim::StageFaults faults;
  faults.stall = OnCalls({2});
  ASSERT_NO_FATAL_FAILURE(Start(faults, /*speed_mm_s=*/1000.0));
  absl::Status status = stage_->Home();
  EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded) << status;
  EXPECT_THAT(Message(status), HasSubstr("homing did not finish"));
  EXPECT_THAT(Message(status), HasSubstr("stalled"));
  EXPECT_TRUE(hardware::IsStalled(status));
  EXPECT_FALSE(emulator_->Busy());
  EXPECT_FALSE(emulator_->Homed());
  absl::StatusOr<hardware::StageState> state = stage_->State();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_FALSE(state->homed);
}

TEST_F(ZaberStageTest, FaultFlagAbortsMovesWithItsMeaning) {
  sim::StageFaults faults;
  faults.warning_flag = "FS";
  ASSERT_NO_FATAL_FAILURE(Start(faults));
  absl::Status home = stage_->Home();
  EXPECT_EQ(home.code(), absl::StatusCode::kAborted) << home;
  EXPECT_THAT(Message(home), HasSubstr("homing failed"));
  EXPECT_THAT(Message(home), HasSubstr("FS (stalled and stopped"));

  absl::Status move = stage_->MoveTo(1.0);
  EXPECT_EQ(move.code(), absl::StatusCode::kAborted) << move;
  EXPECT_THAT(Message(move), HasSubstr("move to 1.000 mm failed"));
  EXPECT_THAT(Message(move), HasSubstr("FS (stalled and stopped"));
  EXPECT_FALSE(emulator_->Busy());  // stopped

  absl::StatusOr<hardware::StageState> state = stage_->State();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_THAT(state->warning_flags, Contains("FS"));
}

TEST_F(ZaberStageTest, WarningFlagsAreSurfacedButDoNotStopMoves) {
  sim::StageFaults faults;
  faults.warning_flag = "WL";  // unexpected limit trigger
  ASSERT_NO_FATAL_FAILURE(Start(faults));
  absl::StatusOr<hardware::StageState> state = stage_->State();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_THAT(state->warning_flags, ElementsAre("WL", "WR"));
  EXPECT_FALSE(state->homed);

  ASSERT_TRUE(stage_->Home().ok());
  ASSERT_TRUE(stage_->MoveTo(3.0).ok());
  state = stage_->State();
  ASSERT_TRUE(state.ok()) << state.status();
  EXPECT_THAT(state->warning_flags, ElementsAre("WL"));
  EXPECT_TRUE(state->homed);
  EXPECT_NEAR(state->position_mm, 3.0, kMicrostepMm);
}

TEST_F(ZaberStageTest, RejectedCommandsAreErrorsNamingTheReason) {
  // The emulator has one axis and answers "RJ ... BADAXIS" for axis 2; a
  // driver configured for axis 2 must say so instead of opening.
  ASSERT_NO_FATAL_FAILURE(Start());
  stage_.reset();  // one client on the pty at a time
  ZaberOptions options = Options();
  options.axis = 2;
  absl::StatusOr<std::unique_ptr<ZaberStage>> other = ZaberStage::Open(options);
  EXPECT_THAT(other,
              StatusIs(absl::StatusCode::kUnavailable, HasSubstr("BADAXIS")));
  EXPECT_THAT(Message(other.status()), HasSubstr("rejected \"get maxspeed\""));
  EXPECT_THAT(Message(other.status()), HasSubstr("BADAXIS"));
}

// A device that sends bytes without ever ending the line (a wrong baud rate
// or a broken cable can): the driver keeps at most a bounded line, calls it
// garbage and resends, instead of buffering until the reply times out. The
// test plays the device on a pseudo-terminal of its own.
TEST(ZaberStageLineTest, AnEndlessReplyLineIsGarbageNotABuffer) {
  const int device = ::posix_openpt(O_RDWR | O_NOCTTY);
  ASSERT_GE(device, 0);
  ASSERT_EQ(::grantpt(device), 0);
  ASSERT_EQ(::unlockpt(device), 0);
  ZaberOptions options;
  options.port = ::ptsname(device);
  options.microstep_um = kMicrostepUm;
  options.travel_mm = 150.0;
  options.reply_timeout = absl::Seconds(2);
  options.retries = 2;
  // The first command (get maxspeed) gets a proper reply, each later one
  // 5000 bytes and no newline.
  std::atomic<int> answered = 0;
  std::thread responder([&] {
    std::string in;
    char buffer[256];
    while (answered < 1 + options.retries + 1) {
      const ssize_t n = ::read(device, buffer, sizeof buffer);
      if (n <= 0) return;
      in.append(buffer, static_cast<size_t>(n));
      for (size_t newline; (newline = in.find('\n')) != std::string::npos;) {
        in.erase(0, newline + 1);
        const std::string reply = answered == 0 ? "@01 1 OK IDLE -- 153600\r\n"
                                                : std::string(5000, 'x');
        ASSERT_EQ(::write(device, reply.data(), reply.size()),
                  static_cast<ssize_t>(reply.size()));
        ++answered;
      }
    }
  });
  absl::StatusOr<std::unique_ptr<ZaberStage>> stage = ZaberStage::Open(options);
  ASSERT_TRUE(stage.ok()) << stage.status();
  const absl::Status status = (*stage)->Home();
  responder.join();
  EXPECT_EQ(status.code(), absl::StatusCode::kDataLoss) << status;
  EXPECT_THAT(Message(status), HasSubstr("answered \"home\" with garbage: a "
                                         "reply line longer than 1024 bytes: "
                                         "\"xxxx"));
  // The message quotes a bounded prefix, not the 5000 bytes.
  EXPECT_LT(status.message().size(), 300u);
  EXPECT_EQ(answered, 4);  // get maxspeed, then home three times
  stage->reset();
  ::close(device);
}

}  // namespace
}  // namespace hdrstereo::zaber
