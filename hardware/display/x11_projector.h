// SPDX-License-Identifier: GPL-3.0-or-later
//
// A projector driven as a borderless fullscreen X11 window: the projector is
// an X screen (or a region of one, for a second monitor in a Xinerama
// layout), and every pattern is copied to it pixel for pixel.
//
// The projector is lost when the connection to the X server breaks (the
// server stopped, the connection was killed) or another client destroys or
// unmaps the window. A lost connection does not end the process (Xlib's
// default would): every later call returns UNAVAILABLE, and the connection
// is not reopened (the daemon must be restarted). An unmapped window is
// back once it is mapped again.
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
  // Reads what the X server has sent (never waits for it): UNAVAILABLE when
  // the connection is lost or the window destroyed or unmapped.
  absl::Status Check() override;
  // The refresh rate of the RandR CRTC that shows the projector's top-left
  // pixel (its mode's dot clock / (htotal * vtotal)). UNIMPLEMENTED on a
  // server without RandR; UNAVAILABLE when no CRTC with a mode shows that
  // pixel (no output connected there) or the connection is lost.
  absl::StatusOr<double> RefreshHz() override;

 private:
  struct Handles;
  X11Projector(const X11ProjectorOptions& options, cv::Size size,
               std::unique_ptr<Handles> handles);
  // mutex_ held. What the server has sent so far (Check), or everything up
  // to now (after a round trip).
  absl::Status CheckLocked();
  absl::Status SyncAndCheckLocked();

  const X11ProjectorOptions options_;
  const cv::Size size_;
  std::mutex mutex_;  // Xlib calls from one thread at a time
  std::unique_ptr<Handles> x_;
};

}  // namespace hdrstereo::display

#endif  // HDRSTEREO_HARDWARE_DISPLAY_X11_PROJECTOR_H_
