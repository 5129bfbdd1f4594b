// SPDX-License-Identifier: GPL-3.0-or-later
//
// A private Xvfb X server for tests that need a display (the projector).
#ifndef HDRSTEREO_TESTS_SUPPORT_XVFB_H_
#define HDRSTEREO_TESTS_SUPPORT_XVFB_H_

#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::testing {

class Xvfb {
 public:
  // Starts Xvfb on a free display number with one screen of the given size
  // (24-bit) and waits until it accepts connections.
  static absl::StatusOr<std::unique_ptr<Xvfb>> Start(int width, int height);

  const std::string& display() const { return display_; }  // e.g. ":123"
  // The screen's pixels in `region`, as BGR (empty on failure).
  cv::Mat Screenshot(cv::Rect region) const;

 private:
  Xvfb(std::string display, Process process)
      : display_(std::move(display)), process_(std::move(process)) {}
  std::string display_;
  Process process_;  // killed on destruction
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_XVFB_H_
