// SPDX-License-Identifier: GPL-3.0-or-later
//
// A projector showing structured-light patterns. Implementations: display/
// (a borderless fullscreen X11 window on the projector's screen), sim/.
#ifndef HDRSTEREO_HARDWARE_PROJECTOR_H_
#define HDRSTEREO_HARDWARE_PROJECTOR_H_

#include <opencv2/core.hpp>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace hdrstereo::hardware {

// INVALID_ARGUMENT unless `pattern` is 8-bit gray or BGR of exactly `size`.
inline absl::Status ValidatePattern(const cv::Mat& pattern, cv::Size size) {
  if (pattern.size() == size &&
      (pattern.type() == CV_8UC1 || pattern.type() == CV_8UC3)) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(
      "pattern is " + std::to_string(pattern.cols) + "x" +
      std::to_string(pattern.rows) + " of OpenCV type " +
      std::to_string(pattern.type()) + "; the projector needs " +
      std::to_string(size.width) + "x" + std::to_string(size.height) +
      " 8-bit gray or BGR");
}

class Projector {
 public:
  virtual ~Projector() = default;

  virtual cv::Size resolution() const = 0;
  // Shows `pattern` (CV_8UC1 or CV_8UC3, exactly resolution()) pixel for
  // pixel and returns once it is on screen and the settle time has passed.
  // A wrong size or type is INVALID_ARGUMENT and the screen is unchanged.
  virtual absl::Status Show(const cv::Mat& pattern) = 0;
  // Shows black.
  virtual absl::Status Blank() = 0;
  // Whether the projector is still there, without showing anything: OK, or
  // UNAVAILABLE saying what was lost (the display connection, the window).
  // Cheap enough to ask before every frame; returns within the driver's
  // own timeout.
  virtual absl::Status Check() = 0;
  // The refresh rate of the display the projector is, in Hz: a pattern
  // changes on a refresh, so a structured-light exposure should last whole
  // refresh periods. UNAVAILABLE (or UNIMPLEMENTED) saying why when the
  // display does not tell.
  virtual absl::StatusOr<double> RefreshHz() = 0;
};

}  // namespace hdrstereo::hardware

#endif  // HDRSTEREO_HARDWARE_PROJECTOR_H_
