// SPDX-License-Identifier: GPL-3.0-or-later
//
// A projector driven as a borderless fullscreen X11 window: the projector is
// an X screen (or a region of one, for a second monitor in a Xinerama
// layout), and every pattern is copied to it pixel for pixel.
#ifndef HDRSTEREO_HARDWARE_DISPLAY_X11_PROJECTOR_H_
#define HDRSTEREO_HARDWARE_DISPLAY_X11_PROJECTOR_H_

#include <memory>
#include <mutex>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "hardware/projector.h"

namespace hdrstereo::display {

struct X11ProjectorOptions {
  std::string display;  // e.g. ":0" or ":0.1"; empty = $DISPLAY
  // Where the projector's pixels are on that screen (Xinerama offset) and
  // its native resolution; 0 = the whole screen.
  int x = 0;
  int y = 0;
  int width_px = 0;
  int height_px = 0;
  // Time for the projector to show a new frame after the X server has it.
  absl::Duration settle_time = absl::Milliseconds(100);
};

class X11Projector final : public hardware::Projector {
 public:
  // UNAVAILABLE when the display cannot be opened or is not 24-bit TrueColor.
  static absl::StatusOr<std::unique_ptr<X11Projector>> Open(
      const X11ProjectorOptions& options);
  ~X11Projector() override;

  cv::Size resolution() const override { return size_; }
  absl::Status Show(const cv::Mat& pattern) override;
  absl::Status Blank() override;

 private:
  struct Handles;
  X11Projector(const X11ProjectorOptions& options, cv::Size size,
               std::unique_ptr<Handles> handles);

  const X11ProjectorOptions options_;
  const cv::Size size_;
  std::mutex mutex_;  // Xlib calls from one thread at a time
  std::unique_ptr<Handles> x_;
};

}  // namespace hdrstereo::display

#endif  // HDRSTEREO_HARDWARE_DISPLAY_X11_PROJECTOR_H_
