// SPDX-License-Identifier: GPL-3.0-or-later
//
// The projector window under a private Xvfb: what is shown is read back from
// the X server with XGetImage and compared pixel for pixel.
#include "hardware/display/x11_projector.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "tests/support/status_matchers.h"
#include "tests/support/xvfb.h"

// Last: Xlib's macros (Status, None, Bool) clash with C++ names.
#include <X11/Xlib.h>
#include <X11/extensions/Xrandr.h>
#undef Status

namespace hdrstereo::display {
namespace {

using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::StatusIs;
using ::hdrstereo::testing::Xvfb;
using ::testing::HasSubstr;

// Another X client on the same display, doing to the projector's window
// what a person or a desktop could do.
class OtherClient {
 public:
  explicit OtherClient(const std::string& display)
      : display_(XOpenDisplay(display.c_str())) {}
  ~OtherClient() {
    if (display_ != nullptr) XCloseDisplay(display_);
  }
  bool ok() const { return display_ != nullptr; }

  // The top-level window called "hdrstereo projector" (0 if none).
  Window Projector() {
    Window root_return = 0, parent = 0;
    Window* children = nullptr;
    unsigned count = 0;
    Window found = 0;
    XQueryTree(display_, DefaultRootWindow(display_), &root_return, &parent,
               &children, &count);
    for (unsigned i = 0; i < count && found == 0; ++i) {
      char* name = nullptr;
      if (XFetchName(display_, children[i], &name) != 0 && name != nullptr) {
        if (std::string(name) == "hdrstereo projector") found = children[i];
        XFree(name);
      }
    }
    if (children != nullptr) XFree(children);
    return found;
  }
  void Unmap(Window window) {
    XUnmapWindow(display_, window);
    XSync(display_, False);
  }
  void Map(Window window) {
    XMapWindow(display_, window);
    XSync(display_, False);
  }
  void Destroy(Window window) {
    XDestroyWindow(display_, window);
    XSync(display_, False);
  }
  // Gives the screen's output a mode with timings (VESA 800x600 at 60.32
  // Hz: 40 MHz / (1056 x 628)); Xvfb's own has none. False if refused.
  bool SetTimedMode() {
    const Window root = DefaultRootWindow(display_);
    XRRScreenResources* resources =
        XRRGetScreenResourcesCurrent(display_, root);
    if (resources == nullptr || resources->ncrtc < 1 ||
        resources->noutput < 1) {
      return false;
    }
    XRRModeInfo mode{};
    char name[] = "800x600_60";
    mode.width = 800;
    mode.height = 600;
    mode.dotClock = 40000000;
    mode.hSyncStart = 840;
    mode.hSyncEnd = 968;
    mode.hTotal = 1056;
    mode.vSyncStart = 601;
    mode.vSyncEnd = 605;
    mode.vTotal = 628;
    mode.name = name;
    mode.nameLength = sizeof name - 1;
    const RRMode id = XRRCreateMode(display_, root, &mode);
    XRRAddOutputMode(display_, resources->outputs[0], id);
    const int set =
        XRRSetCrtcConfig(display_, resources, resources->crtcs[0], CurrentTime,
                         0, 0, id, RR_Rotate_0, resources->outputs, 1);
    XRRFreeScreenResources(resources);
    XSync(display_, False);
    return set == RRSetConfigSuccess;
  }

 private:
  Display* display_;
};

// Column Gray-code bit plane `bit` (0 = most significant of 10 bits).
cv::Mat GrayCodeColumns(cv::Size size, int bit) {
  cv::Mat pattern(size, CV_8UC1);
  for (int x = 0; x < size.width; ++x) {
    const int gray = x ^ (x >> 1);
    pattern.col(x).setTo((gray >> (9 - bit)) & 1 ? 255 : 0);
  }
  return pattern;
}

class X11ProjectorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    absl::StatusOr<std::unique_ptr<Xvfb>> xvfb = Xvfb::Start(800, 600);
    ASSERT_TRUE(xvfb.ok()) << xvfb.status();
    xvfb_ = *std::move(xvfb);
  }
  std::unique_ptr<Xvfb> xvfb_;
};

TEST_F(X11ProjectorTest, ShowsGrayCodeAndNoisePixelExact) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector = X11Projector::Open(
      {.display = xvfb_->display(), .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(projector.ok()) << projector.status();
  ASSERT_EQ((*projector)->resolution(), cv::Size(800, 600));

  for (int bit : {0, 4, 9}) {
    cv::Mat pattern = GrayCodeColumns({800, 600}, bit);
    ASSERT_TRUE((*projector)->Show(pattern).ok());
    cv::Mat shown = xvfb_->Screenshot({0, 0, 800, 600});
    cv::Mat expected;
    cv::cvtColor(pattern, expected, cv::COLOR_GRAY2BGR);
    EXPECT_EQ(cv::norm(shown, expected, cv::NORM_INF), 0) << "bit " << bit;
  }

  // Arbitrary colour content, to catch channel order or stride mistakes.
  cv::Mat noise(600, 800, CV_8UC3);
  cv::randu(noise, 0, 256);
  ASSERT_TRUE((*projector)->Show(noise).ok());
  EXPECT_EQ(cv::norm(xvfb_->Screenshot({0, 0, 800, 600}), noise, cv::NORM_INF),
            0);

  ASSERT_TRUE((*projector)->Blank().ok());
  EXPECT_EQ(
      cv::countNonZero(cv::Mat(xvfb_->Screenshot({0, 0, 800, 600})).reshape(1)),
      0);
}

TEST_F(X11ProjectorTest, RegionOfAScreenForASecondMonitor) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector =
      X11Projector::Open({.display = xvfb_->display(),
                          .x = 160,
                          .y = 100,
                          .width_px = 320,
                          .height_px = 240,
                          .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(projector.ok()) << projector.status();
  cv::Mat pattern(240, 320, CV_8UC1);
  cv::randu(pattern, 0, 256);
  ASSERT_TRUE((*projector)->Show(pattern).ok());
  cv::Mat expected;
  cv::cvtColor(pattern, expected, cv::COLOR_GRAY2BGR);
  EXPECT_EQ(
      cv::norm(xvfb_->Screenshot({160, 100, 320, 240}), expected, cv::NORM_INF),
      0);
}

TEST_F(X11ProjectorTest, WrongSizeOrTypeIsRefusedAndScreenUnchanged) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector = X11Projector::Open(
      {.display = xvfb_->display(), .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(projector.ok());
  cv::Mat white(600, 800, CV_8UC1, cv::Scalar(255));
  ASSERT_TRUE((*projector)->Show(white).ok());
  EXPECT_EQ((*projector)->Show(cv::Mat::zeros(480, 640, CV_8UC1)).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ((*projector)->Show(cv::Mat::zeros(600, 800, CV_32FC1)).code(),
            absl::StatusCode::kInvalidArgument);
  cv::Mat shown = xvfb_->Screenshot({0, 0, 800, 600});
  EXPECT_EQ(cv::countNonZero(shown.reshape(1) != 255), 0);
}

// Check() reports a window another client unmapped or destroyed, and a lost
// display, as UNAVAILABLE naming what is gone, without ending the process
// (Xlib's default for a lost connection); an unmapped window that is mapped
// again is back. Show() into a lost projector is refused the same way.
TEST_F(X11ProjectorTest, ALostWindowOrDisplayIsReportedNotFatal) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector = X11Projector::Open(
      {.display = xvfb_->display(), .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(projector.ok()) << projector.status();
  EXPECT_THAT((*projector)->Check(), IsOk());
  const cv::Mat white(600, 800, CV_8UC1, cv::Scalar(255));
  {
    OtherClient other(xvfb_->display());
    ASSERT_TRUE(other.ok());
    const Window window = other.Projector();
    ASSERT_NE(window, 0u);

    other.Unmap(window);
    // Show waits for the server, so it knows of the unmap.
    EXPECT_THAT((*projector)->Show(white),
                StatusIs(absl::StatusCode::kUnavailable,
                         HasSubstr("was unmapped by another X client")));
    EXPECT_THAT((*projector)->Check(),
                StatusIs(absl::StatusCode::kUnavailable,
                         HasSubstr(absl::StrCat("the projector window on X "
                                                "display \"",
                                                xvfb_->display(), "\""))));
    other.Map(window);
    EXPECT_THAT((*projector)->Show(white), IsOk());
    EXPECT_THAT((*projector)->Check(), IsOk());

    other.Destroy(window);
    EXPECT_THAT((*projector)->Blank(),
                StatusIs(absl::StatusCode::kUnavailable,
                         HasSubstr("was destroyed by another X client")));
    EXPECT_THAT((*projector)->Check(),
                StatusIs(absl::StatusCode::kUnavailable,
                         HasSubstr("was destroyed by another X client")));
  }  // the other client disconnects while the server still runs

  xvfb_.reset();  // the X server stops
  for (int i = 0; i < 2; ++i) {
    EXPECT_THAT((*projector)->Check(),
                StatusIs(absl::StatusCode::kUnavailable,
                         HasSubstr("lost the connection to X display")));
  }
  EXPECT_THAT((*projector)->Show(white),
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("lost the connection to X display")));
  projector->reset();  // closing a lost display does not end the process
}

// The refresh rate comes from the RandR mode of the CRTC that shows the
// projector: Xvfb's own mode has no timings (unknown, said so); one with
// timings gives dot clock / (htotal x vtotal); a projector where no output
// shows anything has none.
TEST_F(X11ProjectorTest, RefreshRateIsTheModeOfTheProjectorsCrtc) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector = X11Projector::Open(
      {.display = xvfb_->display(), .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(projector.ok()) << projector.status();
  EXPECT_THAT((*projector)->RefreshHz(),
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("reports a mode without timings for the "
                                 "projector at +0+0")));
  OtherClient other(xvfb_->display());
  ASSERT_TRUE(other.ok());
  ASSERT_TRUE(other.SetTimedMode());
  absl::StatusOr<double> hz = (*projector)->RefreshHz();
  ASSERT_THAT(hz, IsOk());
  EXPECT_DOUBLE_EQ(*hz, 40e6 / (1056.0 * 628.0));

  absl::StatusOr<std::unique_ptr<X11Projector>> beside =
      X11Projector::Open({.display = xvfb_->display(),
                          .x = 900,
                          .width_px = 64,
                          .height_px = 48,
                          .settle_time = absl::ZeroDuration()});
  ASSERT_TRUE(beside.ok()) << beside.status();
  EXPECT_THAT((*beside)->RefreshHz(),
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("no active output for the projector at "
                                 "+900+0")));
}

TEST(X11ProjectorOpenTest, MissingDisplayIsAClearError) {
  absl::StatusOr<std::unique_ptr<X11Projector>> projector =
      X11Projector::Open({.display = ":987654"});
  ASSERT_FALSE(projector.ok());
  EXPECT_EQ(projector.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(projector.status().message().find(":987654"),
            absl::string_view::npos);
}

}  // namespace
}  // namespace hdrstereo::display
