// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/reconnecting_camera.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::hardware {

absl::Duration BackoffBefore(const ReconnectOptions& options, int attempt) {
  if (attempt <= 1)
    return std::min(options.initial_backoff, options.max_backoff);
  // Multiplied step by step so that a long outage cannot overflow.
  absl::Duration wait = options.initial_backoff;
  for (int i = 1; i < attempt && wait < options.max_backoff; ++i) {
    wait = wait * options.multiplier;
  }
  return std::min(wait, options.max_backoff);
}

bool IsCameraGone(const absl::Status& status) {
  if (IsCameraStuck(status)) return true;
  if (!absl::IsUnavailable(status) && !absl::IsFailedPrecondition(status) &&
      !absl::IsAborted(status)) {
    return false;
  }
  return absl::StrContains(absl::AsciiStrToLower(status.message()),
                           "disconnected");
}

std::string DescribeConnection(const ConnectionState& state) {
  if (state.connected) return "connected";
  return absl::StrCat("reconnecting (attempt ", state.attempt, ")",
                      state.last_error.ok() ? "" : ": ",
                      state.last_error.message());
}

namespace {

// An opened camera, or why there is none (an opener's null is an error).
absl::StatusOr<std::unique_ptr<Camera>> NotNull(
    absl::StatusOr<std::unique_ptr<Camera>> opened) {
  if (opened.ok() && *opened == nullptr) {
    return absl::InternalError("the camera opener returned no camera");
  }
  return opened;
}

}  // namespace

ReconnectingCamera::ReconnectingCamera(
    absl::StatusOr<std::unique_ptr<Camera>> opened, CameraOpener reopen,
    ReconnectOptions options)
    : reopen_(std::move(reopen)), options_(std::move(options)) {
  opened = NotNull(std::move(opened));
  if (opened.ok()) {
    camera_ = std::shared_ptr<Camera>(*std::move(opened));
  } else {
    state_.connected = false;
    state_.attempt = 1;
    state_.last_error = opened.status();
  }
  thread_ = std::thread(&ReconnectingCamera::Loop, this);
}

ReconnectingCamera::~ReconnectingCamera() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

ConnectionState ReconnectingCamera::Connection() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_;
}

absl::StatusOr<std::shared_ptr<Camera>> ReconnectingCamera::Current() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (camera_ != nullptr) return camera_;
  return absl::UnavailableError(
      absl::StrCat("camera disconnected; ", DescribeConnection(state_)));
}

void ReconnectingCamera::Observe(const std::shared_ptr<Camera>& used,
                                 const absl::Status& status) {
  if (!IsCameraGone(status)) return;
  ConnectionState changed;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Another call may have seen the same drop first.
    if (camera_ != used) return;
    camera_.reset();
    state_.connected = false;
    state_.attempt = 1;
    ++state_.drops;
    state_.last_error = status;
    changed = state_;
  }
  cv_.notify_all();
  Changed(changed);
}

template <typename T, typename Call>
absl::StatusOr<T> ReconnectingCamera::Forward(Call call) {
  ASSIGN_OR_RETURN(std::shared_ptr<Camera> camera, Current());
  absl::StatusOr<T> result = call(*camera);
  if (!result.ok()) Observe(camera, result.status());
  return result;
}

absl::StatusOr<CameraInfo> ReconnectingCamera::Info() {
  return Forward<CameraInfo>([](Camera& c) { return c.Info(); });
}

absl::StatusOr<ExposureSettings> ReconnectingCamera::Configure(
    const ExposureSettings& settings) {
  return Forward<ExposureSettings>(
      [&settings](Camera& c) { return c.Configure(settings); });
}

absl::StatusOr<ExposureSettings> ReconnectingCamera::Settings() {
  return Forward<ExposureSettings>([](Camera& c) { return c.Settings(); });
}

absl::StatusOr<Frame> ReconnectingCamera::Capture() {
  return Forward<Frame>([](Camera& c) { return c.Capture(); });
}

absl::StatusOr<int> ReconnectingCamera::PrepareCaptureGroup() {
  return Forward<int>([](Camera& c) { return c.PrepareCaptureGroup(); });
}

absl::StatusOr<Frame> ReconnectingCamera::Preview() {
  return Forward<Frame>([](Camera& c) { return c.Preview(); });
}

void ReconnectingCamera::Changed(const ConnectionState& state) const {
  if (options_.on_change) options_.on_change(state);
}

void ReconnectingCamera::Loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    cv_.wait(lock, [this] { return stop_ || camera_ == nullptr; });
    if (stop_) return;
    // Wait out the backoff of this attempt; a stop ends the wait.
    const absl::Duration wait = BackoffBefore(options_, state_.attempt);
    if (cv_.wait_for(lock, absl::ToChronoNanoseconds(wait),
                     [this] { return stop_; })) {
      return;
    }
    lock.unlock();
    absl::StatusOr<std::unique_ptr<Camera>> opened = NotNull(
        reopen_ ? reopen_()
                : absl::UnimplementedError("this camera cannot be reopened"));
    lock.lock();
    if (opened.ok()) {
      camera_ = std::shared_ptr<Camera>(*std::move(opened));
      state_.connected = true;
      state_.attempt = 0;
      state_.last_error = absl::OkStatus();
    } else {
      ++state_.attempt;
      state_.last_error = opened.status();
    }
    const ConnectionState changed = state_;
    lock.unlock();
    Changed(changed);
    lock.lock();
  }
}

}  // namespace hdrstereo::hardware
