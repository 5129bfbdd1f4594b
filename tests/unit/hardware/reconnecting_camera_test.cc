// SPDX-License-Identifier: GPL-3.0-or-later
//
// The reconnect decorator's backoff schedule, its classification of errors
// and its state machine, over a fake camera whose reopen fails N times.
#include "hardware/reconnecting_camera.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace hdrstereo::hardware {
namespace {

using ::testing::HasSubstr;

// What the fake cameras and their opener share with the test.
struct FakeWorld {
  std::mutex mutex;
  int opened = 0;           // cameras made by the opener
  int reopen_calls = 0;     // opener calls
  int failing_reopens = 0;  // the next this many reopens fail
  absl::Status next_error;  // what the next camera call returns (once)
  int calls = 0;            // camera calls that reached a camera
  int last_camera = 0;      // the id of the camera that answered last
};

ExposureSettings Exposure(double seconds) {
  ExposureSettings settings;
  settings.exposure_s = seconds;
  return settings;
}

class FakeCamera final : public Camera {
 public:
  FakeCamera(std::shared_ptr<FakeWorld> world, int id)
      : world_(std::move(world)), id_(id) {}

  absl::StatusOr<CameraInfo> Info() override {
    if (absl::Status s = Enter(); !s.ok()) return s;
    CameraInfo info;
    info.model = "fake";
    info.serial = absl::StrCat(id_);
    return info;
  }
  absl::StatusOr<ExposureSettings> Configure(
      const ExposureSettings& settings) override {
    if (absl::Status s = Enter(); !s.ok()) return s;
    return settings;
  }
  absl::StatusOr<ExposureSettings> Settings() override {
    if (absl::Status s = Enter(); !s.ok()) return s;
    ExposureSettings settings;
    settings.exposure_s = 0.01;
    return settings;
  }
  absl::StatusOr<Frame> Capture() override {
    if (absl::Status s = Enter(); !s.ok()) return s;
    Frame frame;
    frame.bytes = absl::StrCat("frame of camera ", id_);
    return frame;
  }
  absl::StatusOr<int> PrepareCaptureGroup() override {
    if (absl::Status s = Enter(); !s.ok()) return s;
    return 0;
  }

 private:
  // Counts the call; returns the world's scripted error, if any.
  absl::Status Enter() {
    std::lock_guard<std::mutex> lock(world_->mutex);
    ++world_->calls;
    world_->last_camera = id_;
    absl::Status error = world_->next_error;
    world_->next_error = absl::OkStatus();
    return error;
  }

  std::shared_ptr<FakeWorld> world_;
  const int id_;
};

class ReconnectingCameraTest : public ::testing::Test {
 protected:
  // A camera opened at once, or, when `first_open` is an error, one that
  // could not be opened at first.
  std::unique_ptr<ReconnectingCamera> Make(
      ReconnectOptions options, absl::Status first_open = absl::OkStatus()) {
    auto opener = [world =
                       world_]() -> absl::StatusOr<std::unique_ptr<Camera>> {
      std::lock_guard<std::mutex> lock(world->mutex);
      ++world->reopen_calls;
      if (world->failing_reopens > 0) {
        --world->failing_reopens;
        return absl::UnavailableError(
            absl::StrCat("no camera found (reopen ", world->reopen_calls, ")"));
      }
      return std::make_unique<FakeCamera>(world, ++world->opened);
    };
    absl::StatusOr<std::unique_ptr<Camera>> first;
    if (first_open.ok()) {
      std::lock_guard<std::mutex> lock(world_->mutex);
      first = std::make_unique<FakeCamera>(world_, ++world_->opened);
    } else {
      first = first_open;
    }
    options.on_change = [this](const ConnectionState& state) {
      std::lock_guard<std::mutex> lock(changes_mutex_);
      changes_.push_back(state);
    };
    return std::make_unique<ReconnectingCamera>(std::move(first), opener,
                                                std::move(options));
  }

  void FailNextCall(absl::Status status) {
    std::lock_guard<std::mutex> lock(world_->mutex);
    world_->next_error = std::move(status);
  }

  // Waits (bounded: 2000 polls of 5 ms) until `done` holds for the camera's
  // state; returns whether it did.
  static bool WaitFor(const ReconnectingCamera& camera,
                      const std::function<bool(const ConnectionState&)>& done) {
    for (int i = 0; i < 2000; ++i) {
      if (done(camera.Connection())) return true;
      absl::SleepFor(absl::Milliseconds(5));
    }
    return done(camera.Connection());
  }

  std::vector<ConnectionState> Changes() {
    std::lock_guard<std::mutex> lock(changes_mutex_);
    return changes_;
  }

  static ReconnectOptions Fast() {
    ReconnectOptions options;
    options.initial_backoff = absl::Milliseconds(1);
    options.max_backoff = absl::Milliseconds(4);
    return options;
  }

  std::shared_ptr<FakeWorld> world_ = std::make_shared<FakeWorld>();
  std::mutex changes_mutex_;
  std::vector<ConnectionState> changes_;
};

TEST(BackoffTest, DoublesFromHalfASecondUpToThirtySeconds) {
  const ReconnectOptions options;  // the defaults the daemon uses
  EXPECT_EQ(BackoffBefore(options, 1), absl::Milliseconds(500));
  EXPECT_EQ(BackoffBefore(options, 2), absl::Seconds(1));
  EXPECT_EQ(BackoffBefore(options, 3), absl::Seconds(2));
  EXPECT_EQ(BackoffBefore(options, 4), absl::Seconds(4));
  EXPECT_EQ(BackoffBefore(options, 5), absl::Seconds(8));
  EXPECT_EQ(BackoffBefore(options, 6), absl::Seconds(16));
  EXPECT_EQ(BackoffBefore(options, 7), absl::Seconds(30));
  EXPECT_EQ(BackoffBefore(options, 8), absl::Seconds(30));
  // A camera away for days neither overflows nor waits longer.
  EXPECT_EQ(BackoffBefore(options, 1000000), absl::Seconds(30));
  EXPECT_EQ(BackoffBefore(options, 0), absl::Milliseconds(500));
}

TEST(BackoffTest, FollowsItsOptions) {
  ReconnectOptions options;
  options.initial_backoff = absl::Milliseconds(10);
  options.multiplier = 3;
  options.max_backoff = absl::Milliseconds(100);
  EXPECT_EQ(BackoffBefore(options, 1), absl::Milliseconds(10));
  EXPECT_EQ(BackoffBefore(options, 2), absl::Milliseconds(30));
  EXPECT_EQ(BackoffBefore(options, 3), absl::Milliseconds(90));
  EXPECT_EQ(BackoffBefore(options, 4), absl::Milliseconds(100));
}

TEST(IsCameraGoneTest, DisconnectsAreGoneOtherFailuresAreNot) {
  // The simulator's and gphoto2's words for a camera that went away.
  EXPECT_TRUE(IsCameraGone(absl::AbortedError(
      "camera disconnected during transfer (simulated fault, call 4)")));
  EXPECT_TRUE(IsCameraGone(absl::FailedPreconditionError(
      "camera disconnected (simulated); reconnect first")));
  EXPECT_TRUE(IsCameraGone(absl::UnavailableError(
      "capture: I/O error talking to the camera (disconnected?) (Could not "
      "find the requested device on the USB port)")));
  // A camera that is there but refuses or fails one call.
  EXPECT_FALSE(IsCameraGone(absl::OkStatus()));
  EXPECT_FALSE(IsCameraGone(absl::UnavailableError("camera busy")));
  EXPECT_FALSE(IsCameraGone(
      absl::DeadlineExceededError("camera timed out (simulated fault)")));
  EXPECT_FALSE(IsCameraGone(
      absl::InvalidArgumentError("exposure is disconnected from reality")));
  EXPECT_FALSE(IsCameraGone(absl::FailedPreconditionError(
      "the camera did not take the setting (mode dial not on M?)")));
  // A call the driver could not get back holds the connection: gone,
  // whatever its code; the mark is what says so, not the words.
  EXPECT_TRUE(IsCameraGone(CameraStuckError(absl::DeadlineExceededError(
      "capture: no answer from the camera within 30s"))));
  EXPECT_TRUE(IsCameraGone(CameraStuckError(absl::UnavailableError(
      "cannot read the camera configuration: the camera is still stuck"))));
  EXPECT_FALSE(IsCameraStuck(absl::DeadlineExceededError("camera stuck")));
}

TEST_F(ReconnectingCameraTest, ForwardsCallsWhileConnected) {
  std::unique_ptr<ReconnectingCamera> camera = Make(Fast());
  absl::StatusOr<Frame> frame = camera->Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->bytes, "frame of camera 1");
  EXPECT_TRUE(camera->Configure(Exposure(0.5)).ok());
  EXPECT_TRUE(camera->Info().ok());
  EXPECT_TRUE(camera->Settings().ok());
  EXPECT_TRUE(camera->PrepareCaptureGroup().ok());
  const ConnectionState state = camera->Connection();
  EXPECT_TRUE(state.connected);
  EXPECT_EQ(state.drops, 0);
  EXPECT_EQ(DescribeConnection(state), "connected");
  EXPECT_EQ(world_->reopen_calls, 0);
}

TEST_F(ReconnectingCameraTest, OtherErrorsPassThroughWithoutADrop) {
  std::unique_ptr<ReconnectingCamera> camera = Make(Fast());
  FailNextCall(absl::UnavailableError("camera busy"));
  EXPECT_THAT(std::string(camera->Capture().status().message()),
              HasSubstr("busy"));
  FailNextCall(absl::DeadlineExceededError("timed out"));
  EXPECT_TRUE(absl::IsDeadlineExceeded(camera->Capture().status()));
  EXPECT_TRUE(camera->Connection().connected);
  EXPECT_EQ(camera->Connection().drops, 0);
  EXPECT_TRUE(camera->Capture().ok());
  EXPECT_EQ(world_->reopen_calls, 0);
}

// A drop, three failed reopens, then the camera is back: the state counts
// the attempts, calls in between fail fast without reaching a camera or
// counting as drops, and afterwards calls go to the new camera.
TEST_F(ReconnectingCameraTest, ADropIsReopenedAfterFailedAttempts) {
  // Long enough that the test sees the first attempt pending.
  ReconnectOptions options;
  options.initial_backoff = absl::Milliseconds(200);
  options.multiplier = 1;
  options.max_backoff = absl::Milliseconds(200);
  world_->failing_reopens = 3;
  std::unique_ptr<ReconnectingCamera> camera = Make(options);
  ASSERT_TRUE(camera->Capture().ok());

  FailNextCall(absl::AbortedError("camera disconnected during transfer"));
  absl::Status dropped = camera->Capture().status();
  EXPECT_TRUE(absl::IsAborted(dropped)) << "the call's own error";
  ConnectionState state = camera->Connection();
  EXPECT_FALSE(state.connected);
  EXPECT_EQ(state.drops, 1);
  EXPECT_EQ(state.attempt, 1);
  EXPECT_THAT(std::string(state.last_error.message()),
              HasSubstr("disconnected during transfer"));
  EXPECT_THAT(DescribeConnection(state),
              HasSubstr("reconnecting (attempt 1): camera disconnected"));

  const int calls_before = world_->calls;
  absl::Status away = camera->Capture().status();
  EXPECT_TRUE(absl::IsUnavailable(away)) << away;
  EXPECT_THAT(std::string(away.message()),
              HasSubstr("camera disconnected; reconnecting (attempt"));
  EXPECT_TRUE(IsCameraGone(away));
  EXPECT_FALSE(camera->Configure(Exposure(0.5)).ok());
  EXPECT_FALSE(camera->PrepareCaptureGroup().ok());
  EXPECT_EQ(world_->calls, calls_before) << "no camera to call while away";
  EXPECT_EQ(camera->Connection().drops, 1) << "a call while away is no drop";

  ASSERT_TRUE(WaitFor(*camera, [](const ConnectionState& s) {
    return s.connected;
  })) << DescribeConnection(camera->Connection());
  state = camera->Connection();
  EXPECT_EQ(state.drops, 1);
  EXPECT_EQ(state.attempt, 0);
  EXPECT_TRUE(state.last_error.ok());
  EXPECT_EQ(world_->reopen_calls, 4);

  absl::StatusOr<Frame> frame = camera->Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->bytes, "frame of camera 2") << "the reopened camera";

  // Every change was reported: the drop, attempts 2..4 pending after each
  // failure, then connected.
  const std::vector<ConnectionState> changes = Changes();
  ASSERT_EQ(changes.size(), 5u);
  EXPECT_FALSE(changes[0].connected);
  EXPECT_EQ(changes[0].attempt, 1);
  for (int i = 1; i <= 3; ++i) {
    EXPECT_FALSE(changes[i].connected);
    EXPECT_EQ(changes[i].attempt, i + 1);
    EXPECT_THAT(std::string(changes[i].last_error.message()),
                HasSubstr(absl::StrCat("reopen ", i, ")")));
  }
  EXPECT_TRUE(changes[4].connected);
}

// A camera that could not be opened at first starts away and is opened
// like one that dropped; no drop is counted.
TEST_F(ReconnectingCameraTest, ACameraNotThereAtTheStartIsOpenedLater) {
  world_->failing_reopens = 2;
  std::unique_ptr<ReconnectingCamera> camera =
      Make(Fast(), absl::UnavailableError("no camera found (at the start)"));
  ConnectionState state = camera->Connection();
  EXPECT_FALSE(state.connected);
  EXPECT_EQ(state.attempt, 1);
  EXPECT_EQ(state.drops, 0);
  EXPECT_EQ(DescribeConnection(state),
            "reconnecting (attempt 1): no camera found (at the start)");
  absl::Status away = camera->Capture().status();
  EXPECT_TRUE(absl::IsUnavailable(away)) << away;
  EXPECT_TRUE(IsCameraGone(away));
  EXPECT_EQ(world_->calls, 0);

  ASSERT_TRUE(WaitFor(*camera, [](const ConnectionState& s) {
    return s.connected;
  })) << DescribeConnection(camera->Connection());
  EXPECT_EQ(camera->Connection().drops, 0);
  EXPECT_EQ(world_->reopen_calls, 3);
  absl::StatusOr<Frame> frame = camera->Capture();
  ASSERT_TRUE(frame.ok()) << frame.status();
  EXPECT_EQ(frame->bytes, "frame of camera 1") << "the first one opened";
  // Reported: attempts 2 and 3 pending, then connected.
  const std::vector<ConnectionState> changes = Changes();
  ASSERT_EQ(changes.size(), 3u);
  EXPECT_EQ(changes[0].attempt, 2);
  EXPECT_EQ(changes[1].attempt, 3);
  EXPECT_TRUE(changes[2].connected);
}

TEST_F(ReconnectingCameraTest, EveryCameraCallCanSeeTheDrop) {
  std::unique_ptr<ReconnectingCamera> camera = Make(Fast());
  const absl::Status gone =
      absl::UnavailableError("I/O error talking to the camera (disconnected?)");
  int64_t drops = 0;
  auto expect_drop_and_return = [&](const absl::Status& status) {
    EXPECT_FALSE(status.ok());
    EXPECT_EQ(camera->Connection().drops, ++drops);
    ASSERT_TRUE(
        WaitFor(*camera, [](const ConnectionState& s) { return s.connected; }));
  };
  FailNextCall(gone);
  expect_drop_and_return(camera->Info().status());
  FailNextCall(gone);
  expect_drop_and_return(camera->Configure(Exposure(1)).status());
  FailNextCall(gone);
  expect_drop_and_return(camera->Settings().status());
  FailNextCall(gone);
  expect_drop_and_return(camera->PrepareCaptureGroup().status());
  FailNextCall(gone);
  expect_drop_and_return(camera->Capture().status());
  EXPECT_EQ(world_->reopen_calls, 5);
  EXPECT_TRUE(camera->Capture().ok());
}

// A camera that never comes back: attempts go on (the state says how many)
// until the decorator is destroyed, which does not wait out a backoff.
TEST_F(ReconnectingCameraTest,
       ACameraThatNeverComesBackKeepsTryingUntilStopped) {
  world_->failing_reopens = 1 << 30;
  std::unique_ptr<ReconnectingCamera> camera = Make(Fast());
  FailNextCall(absl::FailedPreconditionError("camera disconnected"));
  EXPECT_FALSE(camera->Capture().ok());
  ASSERT_TRUE(WaitFor(*camera,
                      [](const ConnectionState& s) { return s.attempt >= 6; }));
  const ConnectionState state = camera->Connection();
  EXPECT_FALSE(state.connected);
  EXPECT_EQ(state.drops, 1);
  EXPECT_THAT(DescribeConnection(state), HasSubstr("no camera found"));
  camera.reset();
}

TEST_F(ReconnectingCameraTest, DestroyingDuringALongBackoffDoesNotWaitItOut) {
  ReconnectOptions options;
  options.initial_backoff = absl::Hours(1);
  options.max_backoff = absl::Hours(1);
  std::unique_ptr<ReconnectingCamera> camera = Make(options);
  FailNextCall(absl::AbortedError("camera disconnected"));
  EXPECT_FALSE(camera->Capture().ok());
  EXPECT_EQ(camera->Connection().attempt, 1);
  camera.reset();  // a hang here times the test out
  EXPECT_EQ(world_->reopen_calls, 0);
}

// Two threads whose calls fail on the same drop count it once.
TEST_F(ReconnectingCameraTest, ConcurrentCallsOnOneDropCountOneDrop) {
  ReconnectOptions options;
  options.initial_backoff = absl::Hours(1);
  options.max_backoff = absl::Hours(1);
  std::unique_ptr<ReconnectingCamera> camera = Make(options);
  FailNextCall(absl::AbortedError("camera disconnected"));
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i) {
    threads.emplace_back([&camera] { camera->Capture().IgnoreError(); });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(camera->Connection().drops, 1);
  EXPECT_FALSE(camera->Connection().connected);
}

TEST_F(ReconnectingCameraTest, AnOpenerThatReturnsNothingIsAFailedAttempt) {
  ReconnectingCamera camera(
      std::make_unique<FakeCamera>(world_, 1),
      []() -> absl::StatusOr<std::unique_ptr<Camera>> {
        return std::unique_ptr<Camera>();
      },
      Fast());
  FailNextCall(absl::AbortedError("camera disconnected"));
  EXPECT_FALSE(camera.Capture().ok());
  ASSERT_TRUE(
      WaitFor(camera, [](const ConnectionState& s) { return s.attempt >= 2; }));
  EXPECT_THAT(std::string(camera.Connection().last_error.message()),
              HasSubstr("returned no camera"));
}

}  // namespace
}  // namespace hdrstereo::hardware
