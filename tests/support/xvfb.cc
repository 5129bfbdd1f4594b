// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/xvfb.h"

#include <unistd.h>

#include <filesystem>
#include <random>

#include "absl/strings/str_cat.h"

// Last: Xlib's macros (Status, None, Bool) clash with C++ names.
#include <X11/Xlib.h>
#include <X11/Xutil.h>

namespace hdrstereo::testing {

absl::StatusOr<std::unique_ptr<Xvfb>> Xvfb::Start(int width, int height) {
  std::mt19937 rng(static_cast<unsigned>(::getpid()));
  for (int attempt = 0; attempt < 10; ++attempt) {
    const int number = 200 + static_cast<int>(rng() % 700);
    const std::string socket = absl::StrCat("/tmp/.X11-unix/X", number);
    if (std::filesystem::exists(socket) ||
        std::filesystem::exists(absl::StrCat("/tmp/.X", number, "-lock"))) {
      continue;
    }
    const std::string display = absl::StrCat(":", number);
    absl::StatusOr<Process> process =
        Process::Start({"/usr/bin/Xvfb", display, "-screen", "0",
                        absl::StrCat(width, "x", height, "x24"), "-nolisten",
                        "tcp", "-noreset"},
                       "/dev/null");
    if (!process.ok()) return process.status();
    if (WaitForSocket(socket, absl::Seconds(20))) {
      return std::unique_ptr<Xvfb>(new Xvfb(display, *std::move(process)));
    }
    // Lost a race for this number, or Xvfb failed: try another.
  }
  return absl::UnavailableError("could not start Xvfb (is it installed?)");
}

cv::Mat Xvfb::Screenshot(cv::Rect region) const {
  Display* x = XOpenDisplay(display_.c_str());
  if (x == nullptr) return {};
  XImage* image =
      XGetImage(x, DefaultRootWindow(x), region.x, region.y,
                static_cast<unsigned>(region.width),
                static_cast<unsigned>(region.height), AllPlanes, ZPixmap);
  cv::Mat bgr;
  if (image != nullptr) {
    bgr.create(region.size(), CV_8UC3);
    for (int y = 0; y < region.height; ++y) {
      for (int col = 0; col < region.width; ++col) {
        const unsigned long pixel = XGetPixel(image, col, y);
        bgr.at<cv::Vec3b>(y, col) =
            cv::Vec3b(static_cast<uchar>(pixel & 0xff),
                      static_cast<uchar>((pixel >> 8) & 0xff),
                      static_cast<uchar>((pixel >> 16) & 0xff));
      }
    }
    XDestroyImage(image);
  }
  XCloseDisplay(x);
  return bgr;
}

}  // namespace hdrstereo::testing
