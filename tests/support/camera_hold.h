// SPDX-License-Identifier: GPL-3.0-or-later
//
// The test's end of the simulated camera's hold (scene faults.camera.hold
// and hold_fifo, hardware/sim/scene.h): a FIFO the camera waits on inside a
// capture call, so that a test can act at that moment (after a capture
// job's checks at the frame boundary, before the frame is written).
#ifndef HDRSTEREO_TESTS_SUPPORT_CAMERA_HOLD_H_
#define HDRSTEREO_TESTS_SUPPORT_CAMERA_HOLD_H_

#include <filesystem>

#include "absl/time/time.h"

namespace hdrstereo::testing {

class CameraHold {
 public:
  // Makes the FIFO at `path` (for the scene's hold_fifo).
  explicit CameraHold(std::filesystem::path path);
  // Releases a camera that is still held (or waiting to be), removes the
  // FIFO.
  ~CameraHold();
  CameraHold(const CameraHold&) = delete;
  CameraHold& operator=(const CameraHold&) = delete;

  const std::filesystem::path& path() const { return path_; }

  // Returns true once the camera is held in its capture call; false when it
  // is not within `timeout` (an infinite one waits as long as it takes).
  bool WaitUntilHeld(absl::Duration timeout = absl::InfiniteDuration());
  // Lets the held camera go on.
  void Release();

 private:
  std::filesystem::path path_;
  int fd_ = -1;  // the write end, open while the camera is held
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_CAMERA_HOLD_H_
