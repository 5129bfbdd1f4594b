// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/sim_world.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <future>
#include <opencv2/imgcodecs.hpp>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "hardware/sim/sim_devices.h"
#include "tests/support/camera_hold.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/sim/test_scenes.h"

namespace hdrstereo::sim {
namespace {

using ::hdrstereo::sim::testing::SmallBundledScene;
using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::StatusIs;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::string Bytes(const cv::Mat& m) {
  return std::string(m.datastart, m.dataend);
}

TEST(SimWorldTest, SameSceneAndSeedGiveIdenticalBytes) {
  Scene scene = SmallBundledScene("lab-lamp");
  SimWorld a(scene), b(scene);
  for (SimWorld* w : {&a, &b}) w->SetStagePosition(37.5);
  const ExposureSettings settings{1.0 / 125, 100};
  const std::string a1 = Bytes(a.RenderExposure(settings));
  const std::string a2 = Bytes(a.RenderExposure(settings));
  const std::string b1 = Bytes(b.RenderExposure(settings));
  const std::string b2 = Bytes(b.RenderExposure(settings));
  EXPECT_EQ(a1, b1);
  EXPECT_EQ(a2, b2);
  EXPECT_NE(a1, a2);  // each frame has its own noise
  absl::StatusOr<SimCapture> ca = a.Capture(settings, ImageFormat::kPng);
  absl::StatusOr<SimCapture> cb = b.Capture(settings, ImageFormat::kPng);
  ASSERT_TRUE(ca.ok() && cb.ok());
  // The pixels are identical; the files differ only in the camera clock
  // stamped into their EXIF, as a real camera's would.
  EXPECT_EQ(Bytes(ca->image), Bytes(cb->image));
  EXPECT_EQ(ca->file_name, cb->file_name);

  scene.seed += 1;
  SimWorld c(scene);
  c.SetStagePosition(37.5);
  EXPECT_NE(Bytes(c.RenderExposure(settings)), a1);
}

TEST(SimWorldTest, StagePositionMovesTheView) {
  SimWorld world(SmallBundledScene("textured"));
  world.SetStagePosition(0);
  const std::string left = Bytes(world.RenderRadiance().radiance);
  world.SetStagePosition(150);
  EXPECT_DOUBLE_EQ(world.StagePosition(), 150);
  EXPECT_NE(Bytes(world.RenderRadiance().radiance), left);
}

TEST(SimWorldTest, CaptureEncodesEveryFormat) {
  SimWorld world(SmallBundledScene("textured"));
  for (ImageFormat f : {ImageFormat::kPng, ImageFormat::kJpeg,
                        ImageFormat::kTiff16, ImageFormat::kDng}) {
    absl::StatusOr<SimCapture> c = world.Capture({1.0 / 60, 100}, f);
    ASSERT_TRUE(c.ok()) << ImageFormatName(f) << ": " << c.status();
    EXPECT_FALSE(c->corrupted);
    if (f == ImageFormat::kDng) {
      EXPECT_EQ(c->image.type(), CV_16UC1);
      continue;
    }
    const std::vector<uint8_t> buf(c->bytes.begin(), c->bytes.end());
    const cv::Mat decoded = cv::imdecode(buf, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(decoded.size(), cv::Size(300, 225)) << ImageFormatName(f);
    EXPECT_EQ(decoded.depth(), f == ImageFormat::kTiff16 ? CV_16U : CV_8U);
    if (f != ImageFormat::kJpeg) {
      EXPECT_EQ(cv::norm(decoded, c->image, cv::NORM_INF), 0.0);
    }
  }
}

// The disconnect fault is recoverable: after it, the configured number of
// reopen attempts fail, then one succeeds and captures work again.
TEST(SimWorldTest, DisconnectEndsAfterTheConfiguredFailedReopens) {
  Scene scene = SmallBundledScene("textured");
  scene.camera_faults.disconnect.calls = {2};
  scene.camera_faults.disconnect_failed_reopens = 2;
  SimWorld world(scene);
  const ExposureSettings s{1.0 / 60, 100};
  EXPECT_TRUE(world.ReopenCamera().ok()) << "connected: nothing to reopen";
  ASSERT_TRUE(world.Capture(s, ImageFormat::kPng).ok());
  EXPECT_EQ(world.Capture(s, ImageFormat::kPng).status().code(),
            absl::StatusCode::kAborted);
  EXPECT_FALSE(world.camera_connected());
  EXPECT_EQ(world.PrepareCaptureGroup().status().code(),
            absl::StatusCode::kFailedPrecondition);
  for (int attempt = 1; attempt <= 2; ++attempt) {
    absl::Status reopen = world.ReopenCamera();
    EXPECT_TRUE(absl::IsUnavailable(reopen)) << reopen;
    EXPECT_THAT(std::string(reopen.message()),
                ::testing::HasSubstr(absl::StrCat("reopen attempt ", attempt,
                                                  " of 2 that fail")));
    EXPECT_FALSE(world.camera_connected());
  }
  EXPECT_TRUE(world.ReopenCamera().ok());
  EXPECT_TRUE(world.camera_connected());
  EXPECT_TRUE(world.PrepareCaptureGroup().ok());
  EXPECT_TRUE(world.Capture(s, ImageFormat::kPng).ok());  // call 3
}

TEST(SimWorldTest, DisconnectWithoutFailedReopensIsPermanentUntilPlugged) {
  Scene scene = SmallBundledScene("textured");
  scene.camera_faults.disconnect.calls = {1};
  ASSERT_EQ(scene.camera_faults.disconnect_failed_reopens, -1);  // default
  SimWorld world(scene);
  const ExposureSettings s{1.0 / 60, 100};
  EXPECT_EQ(world.Capture(s, ImageFormat::kPng).status().code(),
            absl::StatusCode::kAborted);
  for (int attempt = 1; attempt <= 20; ++attempt) {
    absl::Status reopen = world.ReopenCamera();
    ASSERT_TRUE(absl::IsUnavailable(reopen)) << reopen;
    EXPECT_THAT(std::string(reopen.message()),
                ::testing::HasSubstr("does not come back"));
  }
  world.ReconnectCamera();
  EXPECT_TRUE(world.camera_connected());
  EXPECT_TRUE(world.Capture(s, ImageFormat::kPng).ok());
}

// A camera absent from the start is found once the file says it is
// plugged in; until then every camera call fails as after a disconnect.
TEST(SimWorldTest, ACameraAbsentAtTheStartIsFoundOnceItsFileExists) {
  hdrstereo::testing::TempDir dir;
  const std::string plug = (dir / "plug").string();
  absl::StatusOr<Scene> scene = ParseScene(testing::SmallSceneJson(
      "", absl::StrCat(R"("faults": {"camera": {"absent_until_file": ")", plug,
                       R"("}})")));
  ASSERT_THAT(scene, hdrstereo::testing::IsOk());
  EXPECT_EQ(scene->camera_faults.absent_until_file, plug);
  SimWorld world(*scene);
  EXPECT_FALSE(world.camera_connected());
  const ExposureSettings s{1.0 / 60, 100};
  EXPECT_THAT(world.Capture(s, ImageFormat::kPng),
              hdrstereo::testing::StatusIs(
                  absl::StatusCode::kFailedPrecondition,
                  ::testing::HasSubstr("camera disconnected")));
  for (int attempt = 1; attempt <= 3; ++attempt) {
    EXPECT_THAT(world.ReopenCamera(),
                hdrstereo::testing::StatusIs(
                    absl::StatusCode::kUnavailable,
                    ::testing::HasSubstr(absl::StrCat(
                        "no camera found (simulated: not plugged in until ",
                        plug, " exists)"))));
  }
  { std::ofstream(plug) << "1"; }
  EXPECT_THAT(world.ReopenCamera(), hdrstereo::testing::IsOk());
  EXPECT_TRUE(world.camera_connected());
  EXPECT_THAT(world.Capture(s, ImageFormat::kPng), hdrstereo::testing::IsOk());
}

TEST(SimWorldTest, DisconnectFailedReopensIsReadFromTheScene) {
  absl::StatusOr<Scene> scene = ParseScene(testing::SmallSceneJson(
      "", R"("faults": {"camera": {"disconnect": {"calls": [3]},
                                   "disconnect_failed_reopens": 4}})"));
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->camera_faults.disconnect_failed_reopens, 4);
  EXPECT_EQ(scene->camera_faults.disconnect.calls, std::vector<int>{3});
}

TEST(SimWorldTest, CameraFaultsFireOnTheConfiguredCalls) {
  Scene scene = SmallBundledScene("textured");
  scene.camera_faults.busy_first_calls = 2;
  scene.camera_faults.timeout.calls = {3};
  scene.camera_faults.disconnect.calls = {4};
  scene.camera_faults.corrupt.calls = {6};
  SimWorld world(scene);
  const ExposureSettings s{1.0 / 60, 100};
  EXPECT_EQ(world.Capture(s, ImageFormat::kPng).status().code(),
            absl::StatusCode::kUnavailable);
  EXPECT_EQ(world.Capture(s, ImageFormat::kPng).status().code(),
            absl::StatusCode::kUnavailable);
  EXPECT_EQ(world.Capture(s, ImageFormat::kPng).status().code(),
            absl::StatusCode::kDeadlineExceeded);
  EXPECT_EQ(world.Capture(s, ImageFormat::kPng).status().code(),
            absl::StatusCode::kAborted);
  // Disconnected until reconnected; those attempts are not counted as calls.
  EXPECT_EQ(world.Capture(s, ImageFormat::kPng).status().code(),
            absl::StatusCode::kFailedPrecondition);
  world.ReconnectCamera();
  absl::StatusOr<SimCapture> good = world.Capture(s, ImageFormat::kPng);  // 5
  ASSERT_TRUE(good.ok()) << good.status();
  EXPECT_FALSE(good->corrupted);
  absl::StatusOr<SimCapture> bad = world.Capture(s, ImageFormat::kPng);  // 6
  ASSERT_TRUE(bad.ok()) << bad.status();
  EXPECT_TRUE(bad->corrupted);
  const std::vector<uint8_t> buf(bad->bytes.begin(), bad->bytes.end());
  const cv::Mat decoded = cv::imdecode(buf, cv::IMREAD_UNCHANGED);
  EXPECT_TRUE(decoded.empty() || cv::norm(decoded, bad->image) > 0)
      << "the corrupted file decodes to the true image";
  EXPECT_EQ(world.capture_calls(), 6);
}

// The hold: the listed call waits until the test releases it; the test's
// wait returns only once the camera is held (both ends block on the FIFO).
TEST(SimWorldTest, AHeldCaptureWaitsForTheRelease) {
  hdrstereo::testing::TempDir dir;
  hdrstereo::testing::CameraHold hold(dir / "hold");
  Scene scene = SmallBundledScene("textured");
  scene.camera_faults.hold.calls = {2};
  scene.camera_faults.hold_fifo = hold.path().string();
  SimWorld world(scene);
  const ExposureSettings s{1.0 / 60, 100};
  ASSERT_TRUE(world.Capture(s, ImageFormat::kPng).ok());  // call 1: not held
  std::future<absl::StatusOr<SimCapture>> held = std::async(
      std::launch::async, [&] { return world.Capture(s, ImageFormat::kPng); });
  ASSERT_TRUE(hold.WaitUntilHeld());
  EXPECT_EQ(world.capture_calls(), 2);
  hold.Release();
  absl::StatusOr<SimCapture> released = held.get();
  ASSERT_TRUE(released.ok()) << released.status();
  EXPECT_FALSE(released->bytes.empty());
}

TEST(SimWorldTest, AHoldNeedsItsFifo) {
  absl::StatusOr<Scene> scene = ParseScene(testing::SmallSceneJson(
      "", R"("faults": {"camera": {"hold": {"calls": [3]}}})"));
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(scene.status().message()),
              ::testing::HasSubstr("faults.camera.hold_fifo"));
  scene = ParseScene(testing::SmallSceneJson(
      "", R"("faults": {"camera": {"hold": {"calls": [3]},
                                   "hold_fifo": "/run/hold"}})"));
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->camera_faults.hold.calls, std::vector<int>{3});
  EXPECT_EQ(scene->camera_faults.hold_fifo, "/run/hold");
}

TEST(SimWorldTest, ProbabilisticFaultsAreSeeded) {
  FaultTrigger t;
  t.probability = 0.3;
  int fired = 0;
  for (int call = 1; call <= 2000; ++call) {
    const bool a = FaultFires(t, call, 42, 1);
    EXPECT_EQ(a, FaultFires(t, call, 42, 1));
    fired += a;
  }
  // Binomial(2000, 0.3): mean 600, sd 20.5; allow 5 sd.
  EXPECT_NEAR(fired, 600, 103);
}

// A window holds on `lasts` calls from each call it begins on; one that
// begins again while it holds is extended.
TEST(SimWorldTest, FaultWindowsHoldForTheirCallsAndOverlap) {
  FaultWindowState window({.begins = {.calls = {2, 3, 9}}, .lasts = 3}, 1, 1);
  std::vector<int> holds;
  for (int call = 1; call <= 12; ++call) holds.push_back(window.Call());
  EXPECT_THAT(holds, ElementsAre(0, 1, 1, 1, 1, 0, 0, 0, 1, 1, 1, 0));
  // Only the calls that may begin it count for `begins`.
  FaultWindowState patterns({.begins = {.calls = {2}}, .lasts = 2}, 1, 1);
  EXPECT_FALSE(patterns.Call(/*can_begin=*/false));
  EXPECT_FALSE(patterns.Call(/*can_begin=*/true));  // begin call 1
  EXPECT_FALSE(patterns.Call(/*can_begin=*/false));
  EXPECT_TRUE(patterns.Call(/*can_begin=*/true));  // begin call 2
  EXPECT_TRUE(patterns.Call(/*can_begin=*/false));
  EXPECT_FALSE(patterns.Call(/*can_begin=*/false));
}

// The battery reads low for `lasts` readings from the Nth, then full again,
// as the simulated camera reports it.
TEST(SimWorldTest, LowBatteryComesAndGoesByReadings) {
  Scene scene = SmallBundledScene("textured");
  scene.camera_faults.low_battery = {.begins = {.calls = {3}}, .lasts = 2};
  scene.camera_faults.low_battery_percent = 12;
  SimWorld world(scene);
  SimCamera camera(world, {});
  std::vector<int> levels;
  for (int reading = 1; reading <= 6; ++reading) {
    absl::StatusOr<hardware::CameraInfo> info = camera.Info();
    ASSERT_THAT(info, IsOk());
    levels.push_back(info->battery_percent);
  }
  EXPECT_THAT(levels, ElementsAre(100, 100, 12, 12, 100, 100));
}

// The projector is lost on its Nth Show or Blank, stays lost (nothing
// projected) for `lasts` calls, Check included, and comes back showing
// black.
TEST(SimWorldTest, ProjectorLostOnAPatternComesBackByItself) {
  Scene scene = SmallBundledScene("lab-lamp");
  scene.projector_faults.lost = {.begins = {.calls = {2}}, .lasts = 3};
  SimWorld world(scene);
  absl::StatusOr<std::unique_ptr<SimProjector>> projector =
      SimProjector::Create(world);
  ASSERT_THAT(projector, IsOk());
  const cv::Mat white((*projector)->resolution(), CV_8UC1, cv::Scalar(255));
  EXPECT_THAT((*projector)->Show(white), IsOk());  // pattern 1
  EXPECT_THAT((*projector)->Check(), IsOk());      // not a pattern
  EXPECT_THAT((*projector)->Blank(),               // pattern 2: lost
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("projector lost (simulated fault")));
  EXPECT_TRUE(world.ProjectorPattern().empty()) << "a lost projector shines";
  EXPECT_THAT((*projector)->Check(), StatusIs(absl::StatusCode::kUnavailable,
                                              HasSubstr("projector lost")));
  EXPECT_THAT(
      (*projector)->Show(white),
      StatusIs(absl::StatusCode::kUnavailable, HasSubstr("projector lost")));
  EXPECT_THAT((*projector)->Check(), IsOk());  // back
  const cv::Mat shown = world.ProjectorPattern();
  ASSERT_EQ(shown.size(), white.size());
  EXPECT_EQ(cv::countNonZero(shown), 0) << "back, it shows black";
  EXPECT_THAT((*projector)->Show(white), IsOk());
  EXPECT_EQ(cv::countNonZero(world.ProjectorPattern()), white.total());
}

// A pattern shows projector.latency_s * timing.scale after it was given;
// until then renders see the pattern given before it.
TEST(SimWorldTest, TheProjectorShowsAPatternAfterItsLatency) {
  Scene scene = SmallBundledScene("lab-lamp");
  scene.projector.latency_s = 0.25;
  scene.timing.scale = 1;
  scene.timing.projector_settle_s = 0;
  SimWorld world(scene);
  const cv::Mat white(scene.projector.height, scene.projector.width, CV_8UC1,
                      cv::Scalar(255));
  ASSERT_THAT(world.SetProjectorPattern(white), IsOk());
  // Polls (bounded) until the pattern showing has `lit` pixels.
  auto wait_for = [&](int lit) {
    for (int i = 0; i < 2000; ++i) {
      const cv::Mat showing = world.ProjectorPattern();
      if (!showing.empty() && cv::countNonZero(showing) == lit) return true;
      absl::SleepFor(absl::Milliseconds(5));
    }
    return false;
  };
  ASSERT_TRUE(wait_for(static_cast<int>(white.total())));
  const ExposureSettings settings{1.0 / 30, 100};
  const double lit_mean = cv::mean(world.RenderExposure(settings))[0];

  // Black is given: for a quarter second white still shows, in renders and
  // captures too.
  world.BlankProjector();
  EXPECT_EQ(cv::countNonZero(world.ProjectorPattern()), white.total());
  ASSERT_OK_AND_ASSIGN(SimCapture during,
                       world.Capture(settings, ImageFormat::kPng));
  EXPECT_NEAR(cv::mean(during.image)[0], lit_mean, 1.0);
  ASSERT_TRUE(wait_for(0));
  ASSERT_OK_AND_ASSIGN(SimCapture after,
                       world.Capture(settings, ImageFormat::kPng));
  EXPECT_LT(cv::mean(after.image)[0], lit_mean - 5);

  // At time scale 0 (as fast as possible) there is no latency.
  scene.timing.scale = 0;
  SimWorld instant(scene);
  ASSERT_THAT(instant.SetProjectorPattern(white), IsOk());
  EXPECT_EQ(cv::countNonZero(instant.ProjectorPattern()), white.total());
}

// Live view: the camera's field of view at most kPreviewMaxWidth wide,
// exactly RenderFrame through PreviewView with the preview's own noise;
// captures' faults do not count previews.
TEST(SimWorldTest, PreviewIsAReducedRenderWithItsOwnNoise) {
  absl::StatusOr<Scene> full = LoadBundledScene("lab-lamp");
  ASSERT_THAT(full, IsOk());
  Scene scene = *full;
  scene.camera_faults.busy_first_calls = 1;
  SimWorld world(scene);
  world.SetStagePosition(20);
  const ExposureSettings settings{1.0 / 60, 200};
  const View view = PreviewView(scene, 20);
  EXPECT_EQ(view.intrinsics.width, kPreviewMaxWidth);
  EXPECT_EQ(view.intrinsics.height, 360);  // 900 * 480 / 1200
  EXPECT_DOUBLE_EQ(view.intrinsics.fx, scene.camera.fx * 0.4);
  EXPECT_DOUBLE_EQ(view.intrinsics.cx, (scene.camera.cx + 0.5) * 0.4 - 0.5);
  for (int n = 0; n < 2; ++n) {
    ASSERT_OK_AND_ASSIGN(SimCapture preview, world.Preview(settings));
    EXPECT_EQ(preview.format, ImageFormat::kJpeg);
    EXPECT_EQ(preview.frame_index, n);
    const cv::Mat exact = RenderFrame(world.renderer(), view, cv::Mat(),
                                      settings, PreviewNoiseSeed(scene, n));
    EXPECT_EQ(Bytes(preview.image), Bytes(exact)) << "preview " << n;
    const cv::Mat decoded =
        cv::imdecode(cv::Mat(1, static_cast<int>(preview.bytes.size()), CV_8UC1,
                             preview.bytes.data()),
                     cv::IMREAD_COLOR);
    ASSERT_EQ(decoded.size(), cv::Size(480, 360));
  }
  EXPECT_NE(PreviewNoiseSeed(scene, 0), PreviewNoiseSeed(scene, 1));
  // The first capture is still the one the busy fault fires on.
  EXPECT_THAT(world.Capture(settings, ImageFormat::kPng),
              StatusIs(absl::StatusCode::kUnavailable, HasSubstr("busy")));

  // Through the camera interface: a JPEG of the reduced size.
  SimCamera camera(world, {});
  ASSERT_OK_AND_ASSIGN(hardware::Frame frame, camera.Preview());
  EXPECT_EQ(frame.format, hardware::ImageFormat::kJpeg);
  EXPECT_EQ(frame.extension, "jpg");
  EXPECT_EQ(frame.width_px, 480);
  EXPECT_EQ(frame.height_px, 360);
}

TEST(SimWorldTest, PreviewOfADisconnectedCameraFails) {
  Scene scene = SmallBundledScene("textured");
  scene.camera_faults.disconnect = {.calls = {1}};
  SimWorld world(scene);
  const ExposureSettings settings{1.0 / 60, 100};
  EXPECT_THAT(world.Capture(settings, ImageFormat::kPng),
              StatusIs(absl::StatusCode::kAborted));
  EXPECT_THAT(world.Preview(settings),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("camera disconnected (simulated)")));
}

TEST(SimWorldTest, ProjectorPatternValidation) {
  SimWorld lab(SmallBundledScene("lab-lamp"));
  EXPECT_TRUE(lab.SetProjectorPattern(cv::Mat(768, 1024, CV_8UC1)).ok());
  EXPECT_EQ(lab.SetProjectorPattern(cv::Mat(8, 8, CV_16UC1)).code(),
            absl::StatusCode::kInvalidArgument);
  SimWorld textured(SmallBundledScene("textured"));  // has no projector
  EXPECT_EQ(textured.SetProjectorPattern(cv::Mat(8, 8, CV_8UC1)).code(),
            absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace hdrstereo::sim
