// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/display/x11_projector.h"

#include <X11/Xatom.h>
#include <X11/Xlib.h>
#include <X11/Xutil.h>
#include <X11/extensions/Xrandr.h>
// Xlib defines Status as a macro, which would break absl::Status.
#undef Status

#include <cstdio>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::display {
namespace {

// Xlib's default I/O error handler ends the process. This one (process-wide:
// Xlib has no other kind) only says what happened; then each display's exit
// handler runs: ours marks the projector lost, Xlib's default (any other
// display) still exits.
int ReportLostConnection(Display* display) {
  std::fprintf(stderr, "X connection to %s lost\n", DisplayString(display));
  return 0;
}

// Frames per second of a RandR mode; 0 when the mode does not say.
double ModeRate(const XRRModeInfo& mode) {
  double lines = mode.vTotal;
  if (mode.modeFlags & RR_DoubleScan) lines *= 2;
  if (mode.modeFlags & RR_Interlace) lines /= 2;
  if (mode.hTotal == 0 || lines <= 0) return 0;
  return static_cast<double>(mode.dotClock) / (mode.hTotal * lines);
}

}  // namespace

struct X11Projector::Handles {
  Display* display = nullptr;
  Window window = 0;
  GC gc = nullptr;
  Visual* visual = nullptr;
  int depth = 0;
  // What the X server told us (StructureNotify events on the window).
  bool connection_lost = false;
  bool window_destroyed = false;
  bool window_mapped = true;

  // Xlib calls this after the I/O error handler (ReportLostConnection)
  // instead of exit(): the display is then dead, and every later Xlib call
  // on it returns at once.
  static void OnConnectionLost(Display*, void* self) {
    static_cast<Handles*>(self)->connection_lost = true;
  }

  ~Handles() {
    if (display == nullptr) return;
    if (!connection_lost) {
      if (gc != nullptr) XFreeGC(display, gc);
      if (window != 0 && !window_destroyed) XDestroyWindow(display, window);
    }
    XCloseDisplay(display);
  }
};

absl::StatusOr<std::unique_ptr<X11Projector>> X11Projector::Open(
    const X11ProjectorOptions& options) {
  auto x = std::make_unique<Handles>();
  const char* name =
      options.display.empty() ? nullptr : options.display.c_str();
  x->display = XOpenDisplay(name);
  if (x->display == nullptr) {
    return absl::UnavailableError(absl::StrCat(
        "cannot open X display \"",
        name != nullptr ? name
                        : (std::getenv("DISPLAY") ? std::getenv("DISPLAY")
                                                  : "(DISPLAY unset)"),
        "\" for the projector"));
  }
  const int screen = DefaultScreen(x->display);
  XVisualInfo visual_info;
  if (!XMatchVisualInfo(x->display, screen, 24, TrueColor, &visual_info)) {
    return absl::UnavailableError(
        "the projector's X screen has no 24-bit TrueColor visual; patterns "
        "could not be shown pixel-exact");
  }
  x->visual = visual_info.visual;
  x->depth = visual_info.depth;
  XSetIOErrorHandler(&ReportLostConnection);
  XSetIOErrorExitHandler(x->display, &Handles::OnConnectionLost, x.get());

  cv::Size size(options.width_px > 0 ? options.width_px
                                     : DisplayWidth(x->display, screen),
                options.height_px > 0 ? options.height_px
                                      : DisplayHeight(x->display, screen));
  XSetWindowAttributes attributes;
  // No window manager decorations or placement: the window covers exactly
  // the projector's pixels.
  attributes.override_redirect = True;
  attributes.background_pixel = BlackPixel(x->display, screen);
  attributes.colormap = XCreateColormap(
      x->display, RootWindow(x->display, screen), x->visual, AllocNone);
  attributes.border_pixel = 0;
  x->window = XCreateWindow(
      x->display, RootWindow(x->display, screen), options.x, options.y,
      static_cast<unsigned>(size.width), static_cast<unsigned>(size.height), 0,
      x->depth, InputOutput, x->visual,
      CWOverrideRedirect | CWBackPixel | CWColormap | CWBorderPixel,
      &attributes);
  XStoreName(x->display, x->window, "hdrstereo projector");
  // Destroyed, unmapped, mapped again: Check() reads these.
  XSelectInput(x->display, x->window, StructureNotifyMask);
  // Hide the cursor with an empty pixmap cursor.
  char empty = 0;
  Pixmap blank = XCreateBitmapFromData(x->display, x->window, &empty, 1, 1);
  XColor black{};
  Cursor cursor =
      XCreatePixmapCursor(x->display, blank, blank, &black, &black, 0, 0);
  XDefineCursor(x->display, x->window, cursor);
  XFreePixmap(x->display, blank);
  x->gc = XCreateGC(x->display, x->window, 0, nullptr);
  XMapRaised(x->display, x->window);
  XSync(x->display, False);

  auto projector = std::unique_ptr<X11Projector>(
      new X11Projector(options, size, std::move(x)));
  RETURN_IF_ERROR(projector->Blank());
  return projector;
}

X11Projector::X11Projector(const X11ProjectorOptions& options, cv::Size size,
                           std::unique_ptr<Handles> handles)
    : options_(options), size_(size), x_(std::move(handles)) {}

X11Projector::~X11Projector() = default;

absl::Status X11Projector::Show(const cv::Mat& pattern) {
  RETURN_IF_ERROR(hardware::ValidatePattern(pattern, size_));
  // 24-bit TrueColor ZPixmaps are 32 bits per pixel, B G R X in memory on
  // little-endian servers (checked against the visual's masks below).
  cv::Mat bgra;
  cv::cvtColor(
      pattern, bgra,
      pattern.channels() == 1 ? cv::COLOR_GRAY2BGRA : cv::COLOR_BGR2BGRA);
  std::lock_guard<std::mutex> lock(mutex_);
  // Drawing into a window that is gone would be an X error, which ends
  // the process: first a round trip, so that what the server did to the
  // window before now is known.
  RETURN_IF_ERROR(SyncAndCheckLocked());
  if (x_->visual->red_mask != 0xff0000 || x_->visual->green_mask != 0xff00 ||
      x_->visual->blue_mask != 0xff) {
    return absl::UnavailableError(
        "the projector's visual is not 8-8-8 RGB; cannot show exact pixels");
  }
  XImage* image = XCreateImage(
      x_->display, x_->visual, static_cast<unsigned>(x_->depth), ZPixmap, 0,
      reinterpret_cast<char*>(bgra.data), static_cast<unsigned>(size_.width),
      static_cast<unsigned>(size_.height), 32, static_cast<int>(bgra.step));
  if (image == nullptr) return absl::InternalError("XCreateImage failed");
  image->byte_order = LSBFirst;
  XPutImage(x_->display, x_->window, x_->gc, image, 0, 0, 0, 0,
            static_cast<unsigned>(size_.width),
            static_cast<unsigned>(size_.height));
  image->data = nullptr;  // owned by `bgra`
  XDestroyImage(image);
  // Returns once the server has processed the request.
  RETURN_IF_ERROR(SyncAndCheckLocked());
  absl::SleepFor(options_.settle_time);
  return absl::OkStatus();
}

absl::Status X11Projector::Blank() {
  return Show(cv::Mat::zeros(size_, CV_8UC1));
}

absl::Status X11Projector::Check() {
  std::lock_guard<std::mutex> lock(mutex_);
  return CheckLocked();
}

absl::StatusOr<double> X11Projector::RefreshHz() {
  std::lock_guard<std::mutex> lock(mutex_);
  RETURN_IF_ERROR(CheckLocked());
  Display* display = x_->display;
  int event_base = 0;
  int error_base = 0;
  if (!XRRQueryExtension(display, &event_base, &error_base)) {
    return absl::UnimplementedError(absl::StrCat(
        "X display \"", DisplayString(display),
        "\" has no RandR extension: the projector's refresh rate is unknown"));
  }
  XRRScreenResources* resources = XRRGetScreenResourcesCurrent(
      display, RootWindow(display, DefaultScreen(display)));
  if (resources == nullptr) {
    return absl::UnavailableError(
        "RandR gave no screen resources for the projector's screen");
  }
  double rate = 0;
  bool shown = false;
  for (int i = 0; i < resources->ncrtc && !shown; ++i) {
    XRRCrtcInfo* crtc = XRRGetCrtcInfo(display, resources, resources->crtcs[i]);
    if (crtc == nullptr) continue;
    shown = crtc->mode != None && options_.x >= crtc->x &&
            options_.y >= crtc->y &&
            options_.x < crtc->x + static_cast<int>(crtc->width) &&
            options_.y < crtc->y + static_cast<int>(crtc->height);
    for (int m = 0; shown && m < resources->nmode; ++m) {
      if (resources->modes[m].id == crtc->mode) {
        rate = ModeRate(resources->modes[m]);
      }
    }
    XRRFreeCrtcInfo(crtc);
  }
  XRRFreeScreenResources(resources);
  if (!(rate > 0)) {
    return absl::UnavailableError(absl::StrFormat(
        "RandR on X display \"%s\" reports %s for the projector at +%d+%d: "
        "its refresh rate is unknown",
        DisplayString(display),
        shown ? "a mode without timings" : "no active output", options_.x,
        options_.y));
  }
  return rate;
}

absl::Status X11Projector::SyncAndCheckLocked() {
  if (!x_->connection_lost) XSync(x_->display, False);
  return CheckLocked();
}

absl::Status X11Projector::CheckLocked() {
  // XPending reads what has arrived without waiting for more; a closed
  // connection is found there (Xlib's I/O error, see
  // Handles::OnConnectionLost).
  while (!x_->connection_lost && XPending(x_->display) > 0) {
    XEvent event;
    XNextEvent(x_->display, &event);
    if (event.type == DestroyNotify &&
        event.xdestroywindow.window == x_->window) {
      x_->window_destroyed = true;
    } else if (event.type == UnmapNotify && event.xunmap.window == x_->window) {
      x_->window_mapped = false;
    } else if (event.type == MapNotify && event.xmap.window == x_->window) {
      x_->window_mapped = true;
    }
  }
  const std::string display = DisplayString(x_->display);
  if (x_->connection_lost) {
    return absl::UnavailableError(absl::StrCat(
        "lost the connection to X display \"", display,
        "\" (the X server stopped or closed it); restart hdrstereod once the "
        "display is back"));
  }
  if (x_->window_destroyed) {
    return absl::UnavailableError(absl::StrCat(
        "the projector window on X display \"", display,
        "\" was destroyed by another X client; restart hdrstereod"));
  }
  if (!x_->window_mapped) {
    return absl::UnavailableError(absl::StrCat(
        "the projector window on X display \"", display,
        "\" was unmapped by another X client; it is back once mapped again"));
  }
  return absl::OkStatus();
}

}  // namespace hdrstereo::display
