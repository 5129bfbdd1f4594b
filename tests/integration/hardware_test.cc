// SPDX-License-Identifier: GPL-3.0-or-later
//
// The Hardware surface of the real hdrstereod with --hardware sim, driven by
// the real hdrstereo CLI: the stage is the real Zaber driver on the
// emulator's pty, the camera renders the simulated world, and each injected
// fault must come back as a clear error while the daemon keeps serving.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "absl/time/clock.h"
#include "hardware/sim/ptpip_camera.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/free_ports.h"
#include "tests/support/subprocess.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

constexpr double kMicrostepMm = 0.047625 / 1000.0;

// A bundled scene at 320 x 240 (1/3.75 of 1200 x 900), so frames are quick.
nlohmann::json SmallCamera() {
  constexpr double kScale = 320.0 / 1200.0;
  return {{"camera",
           {{"width", 320},
            {"height", 240},
            {"fx", 1600 * kScale},
            {"fy", 1600 * kScale},
            {"cx", 159.5},
            {"cy", 119.5}}}};
}

int64_t IdOf(const nlohmann::json& job) {
  EXPECT_TRUE(job.contains("id")) << job.dump();
  if (!job.contains("id")) return -1;
  return ::hdrstereo::testing::JsonInt(job["id"]);
}

class HardwareTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  // The line of `hw status` for `device` ("camera", "stage", ...).
  std::string StatusLine(const std::string& device) {
    CommandResult status = Cli({"hw", "status"});
    EXPECT_EQ(status.exit_code, 0) << status.err;
    for (absl::string_view line : absl::StrSplit(status.out, '\n')) {
      if (absl::ConsumePrefix(&line, device) && absl::StartsWith(line, " ")) {
        return std::string(absl::StripAsciiWhitespace(line));
      }
    }
    ADD_FAILURE() << "no " << device << " line in\n" << status.out;
    return "";
  }

  nlohmann::json Status() { return CliJson({"hw", "status"}); }

  // Submits a one-exposure stereo capture (left at 0 mm, right at 50 mm)
  // into a new session and returns the job id.
  int64_t SubmitStereo(const std::string& session) {
    EXPECT_EQ(Cli({"session", "create", session}).exit_code, 0);
    nlohmann::json job =
        CliJson({"capture", "stereo", session, "--exposures", "1/125",
                 "--baseline-mm", "50", "--no-ambient"});
    return IdOf(job);
  }
};

TEST_F(HardwareTest, StatusShowsEveryDeviceConnectedInSimulation) {
  StartDaemon();
  CommandResult status = Cli({"hw", "status"});
  ASSERT_EQ(status.exit_code, 0) << status.err;
  EXPECT_EQ(StatusLine("mode"), "sim");
  EXPECT_THAT(StatusLine("camera"),
              StartsWith("connected  hdrstereo simulated camera (lab-lamp)"));
  // Fresh from power-up: at 0 mm, not homed (the emulator's WR flag).
  EXPECT_THAT(StatusLine("stage"),
              StartsWith("connected  0.000 mm not homed [WR]"));
  EXPECT_THAT(StatusLine("projector"), StartsWith("connected  1024x768"));

  nlohmann::json json = Status();
  EXPECT_EQ(json["hardware_mode"], "sim");
  EXPECT_EQ(json["camera"]["state"], "DEVICE_STATE_CONNECTED");
  EXPECT_EQ(json["stage"]["state"], "DEVICE_STATE_CONNECTED");
  EXPECT_EQ(json["stage"]["travel_mm"], 150.0);
  EXPECT_EQ(json["projector"]["state"], "DEVICE_STATE_CONNECTED");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HardwareTest, HomeThenMoveOverThePty) {
  StartDaemon();
  CommandResult home = Cli({"hw", "stage", "home"});
  ASSERT_EQ(home.exit_code, 0) << home.err;
  EXPECT_THAT(home.out, HasSubstr("0.000 mm of 150.0 mm"));

  CommandResult move = Cli({"hw", "stage", "move", "42.5"});
  ASSERT_EQ(move.exit_code, 0) << move.err;
  EXPECT_THAT(move.out, HasSubstr("42.500 mm of 150.0 mm"));

  EXPECT_THAT(StatusLine("stage"), StartsWith("connected  42.500 mm homed"));
  nlohmann::json json = Status();
  EXPECT_NEAR(json["stage"]["position_mm"].get<double>(), 42.5, kMicrostepMm);
  EXPECT_EQ(json["stage"]["homed"], true);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HardwareTest, BadInputsAreInvalidArgumentAndTouchNothing) {
  StartDaemon();
  ASSERT_EQ(Cli({"hw", "stage", "home"}).exit_code, 0);
  ASSERT_EQ(Cli({"hw", "stage", "move", "10"}).exit_code, 0);
  ASSERT_EQ(Cli({"hw", "camera", "set", "--exposure", "1/60", "--iso", "200"})
                .exit_code,
            0);
  ASSERT_EQ(Cli({"hw", "projector", "show", "--level", "128"}).exit_code, 0);
  const nlohmann::json before = Status();
  const nlohmann::json settings_before = CliJson({"hw", "camera", "get"});

  // Beyond the 150 mm travel.
  CommandResult far = Cli({"hw", "stage", "move", "200"});
  EXPECT_EQ(far.exit_code, 2) << far.err;
  EXPECT_THAT(far.err, HasSubstr("outside the stage travel [0, 150] mm"));
  CommandResult negative = Cli({"hw", "stage", "move", "--", "-0.5"});
  EXPECT_EQ(negative.exit_code, 2) << negative.err;

  // Not a positive exposure (the CLI refuses it), then one outside the
  // simulated camera's [1/8000, 30] s (the daemon refuses it).
  CommandResult zero = Cli({"hw", "camera", "set", "--exposure", "0"});
  EXPECT_EQ(zero.exit_code, 2) << zero.err;
  EXPECT_THAT(zero.err, HasSubstr("not a positive time"));
  CommandResult tiny = Cli({"hw", "camera", "set", "--exposure", "1/100000"});
  EXPECT_EQ(tiny.exit_code, 2) << tiny.err;
  EXPECT_THAT(tiny.err, HasSubstr("outside the camera's range"));
  CommandResult slow = Cli({"hw", "camera", "set", "--exposure", "60"});
  EXPECT_EQ(slow.exit_code, 2) << slow.err;
  EXPECT_THAT(slow.err, HasSubstr("outside the camera's range"));

  // A PNG that is not the projector's 1024 x 768.
  const fs::path small_png = dir_ / "small.png";
  ASSERT_TRUE(cv::imwrite(small_png.string(),
                          cv::Mat(100, 120, CV_8UC1, cv::Scalar(255))));
  CommandResult png = Cli({"hw", "projector", "show", small_png.string()});
  EXPECT_EQ(png.exit_code, 2) << png.err;
  EXPECT_THAT(
      png.err,
      HasSubstr("png is 120x100; the projector shows exactly 1024x768"));
  // 1024 columns need 10 Gray-code bits: bit 99 does not exist.
  CommandResult bit = Cli({"hw", "projector", "show", "--gray", "col:99"});
  EXPECT_EQ(bit.exit_code, 2) << bit.err;
  EXPECT_THAT(bit.err, HasSubstr("Gray-code bit 99 is outside [0, 10)"));

  // Nothing changed.
  const nlohmann::json after = Status();
  EXPECT_EQ(after["stage"], before["stage"]);
  EXPECT_NEAR(after["stage"]["position_mm"].get<double>(), 10.0, kMicrostepMm);
  EXPECT_EQ(after["projector"]["showing"], "solid 128");
  EXPECT_EQ(CliJson({"hw", "camera", "get"}), settings_before);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HardwareTest, ProjectorShowsAGrayCodePlane) {
  StartDaemon();
  CommandResult show = Cli({"hw", "projector", "show", "--gray", "col:3"});
  ASSERT_EQ(show.exit_code, 0) << show.err;
  EXPECT_THAT(show.out, HasSubstr("gray code col_b03"));
  EXPECT_THAT(StatusLine("projector"),
              StartsWith("connected  1024x768  gray code col_b03"));

  CommandResult inverse =
      Cli({"hw", "projector", "show", "--gray", "row:2:inv"});
  ASSERT_EQ(inverse.exit_code, 0) << inverse.err;
  EXPECT_THAT(inverse.out, HasSubstr("gray code row_b02 inverse"));

  CommandResult blank = Cli({"hw", "projector", "blank"});
  ASSERT_EQ(blank.exit_code, 0) << blank.err;
  EXPECT_THAT(StatusLine("projector"), HasSubstr("blank"));
  EXPECT_EQ(StopDaemon(), 0);
}

// The camera on the stage sees the scene shift by the stereo disparity:
// the left frame (stage at 0 mm) and the right frame (50 mm), both taken
// through the daemon, the Zaber driver and the pty, agree once the right
// frame is shifted by the simulator's exact disparity.
TEST_F(HardwareTest, FrameContentMovesWithTheStageByTheTrueDisparity) {
  const fs::path scene_path = WriteScene("lab-lamp", SmallCamera());
  StartDaemon({"--sim-scene", scene_path.string()});
  const int64_t job = SubmitStereo("disparity");
  ASSERT_TRUE(WaitForJobState(job, "succeeded")) << Job(job).dump(2);

  // The two frames the job recorded, and where the stage was for each.
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "2");
  EXPECT_EQ(std::stod(Sql("SELECT stage_position_mm FROM frames "
                          "WHERE view_index = 0")),
            0.0);
  EXPECT_EQ(std::stod(Sql("SELECT stage_position_mm FROM frames "
                          "WHERE view_index = 1")),
            50.0);
  const fs::path session = data_root() / "sessions" / "disparity";
  const cv::Mat left_bgr = cv::imread(
      (session / Sql("SELECT path FROM frames WHERE view_index = 0")).string());
  const cv::Mat right_bgr = cv::imread(
      (session / Sql("SELECT path FROM frames WHERE view_index = 1")).string());
  ASSERT_EQ(left_bgr.size(), cv::Size(320, 240));
  ASSERT_EQ(right_bgr.size(), cv::Size(320, 240));
  cv::Mat left, right;
  cv::cvtColor(left_bgr, left, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right_bgr, right, cv::COLOR_BGR2GRAY);
  left.convertTo(left, CV_32F);
  right.convertTo(right, CV_32F);

  // The exact truth for the same scene file, computed in this process.
  absl::StatusOr<sim::Scene> scene = sim::LoadScene(scene_path.string());
  ASSERT_TRUE(scene.ok()) << scene.status();
  sim::SimWorld world(*scene);
  absl::StatusOr<sim::StereoTruth> truth = world.Truth(0, 50);
  ASSERT_TRUE(truth.ok()) << truth.status();
  const cv::Mat& disparity = truth->left.disparity;
  const cv::Mat& visible = truth->left.nonoccluded;

  // The right frame resampled (bilinearly) at u - disparity - offset, so
  // that a correct shift lines it up with the left frame; -1 outside.
  auto shifted_right = [&](double offset, bool use_disparity) {
    cv::Mat map_x(left.size(), CV_32F), map_y(left.size(), CV_32F);
    for (int v = 0; v < left.rows; ++v) {
      for (int u = 0; u < left.cols; ++u) {
        const float d = disparity.at<float>(v, u);
        map_x.at<float>(v, u) = static_cast<float>(
            u - (use_disparity && std::isfinite(d) ? d : 0) - offset);
        map_y.at<float>(v, u) = static_cast<float>(v);
      }
    }
    cv::Mat shifted;
    cv::remap(right, shifted, map_x, map_y, cv::INTER_LINEAR,
              cv::BORDER_CONSTANT, cv::Scalar(-1));
    return shifted;
  };
  const cv::Mat with_truth = shifted_right(0, true);
  const cv::Mat without_shift = shifted_right(0, false);
  const cv::Mat off_by_two = shifted_right(2, true);

  // Compared pixels: seen by both views (truth), textured (|Sobel x| >= 30,
  // about 7 gray levels per pixel: flat regions match under any shift and
  // prove nothing), not clipped, and inside the right frame for all three
  // shifts. Mean absolute gray-level differences over them:
  cv::Mat gradient;
  cv::Sobel(left, gradient, CV_32F, 1, 0, 3);
  double error_truth = 0, error_none = 0, error_off = 0;
  int count = 0;
  for (int v = 1; v < left.rows - 1; ++v) {
    for (int u = 1; u < left.cols - 1; ++u) {
      const float l = left.at<float>(v, u);
      if (!std::isfinite(disparity.at<float>(v, u)) ||
          visible.at<uchar>(v, u) != 255 ||
          std::abs(gradient.at<float>(v, u)) < 30 || l <= 2 || l >= 253 ||
          with_truth.at<float>(v, u) < 0 || without_shift.at<float>(v, u) < 0 ||
          off_by_two.at<float>(v, u) < 0) {
        continue;
      }
      error_truth += std::abs(l - with_truth.at<float>(v, u));
      error_none += std::abs(l - without_shift.at<float>(v, u));
      error_off += std::abs(l - off_by_two.at<float>(v, u));
      ++count;
    }
  }
  ASSERT_GE(count, 500) << "too few textured, visible pixels to compare";
  error_truth /= count;
  error_none /= count;
  error_off /= count;
  std::cerr << "mean |L - R| on " << count << " pixels: true disparity "
            << error_truth << ", no shift " << error_none << ", off by 2 px "
            << error_off << "\n";
  // Thresholds: with the true disparity the mismatch (noise and resampling
  // only) is under a third of that without a shift, under 1/1.5 of that
  // with a shift 2 px off, and under 5 gray levels.
  EXPECT_LT(error_truth, error_none / 3);
  EXPECT_LT(error_truth, error_off / 1.5);
  EXPECT_LT(error_truth, 5.0);
  EXPECT_EQ(StopDaemon(), 0);
}

// A camera that times out at every attempt at the first frame (a single
// timeout is taken again: CaptureTest).
TEST_F(HardwareTest, CameraTimeoutFailsTheCaptureWithTheCamerasMessage) {
  nlohmann::json patch = SmallCamera();
  patch["faults"] = {{"camera", {{"timeout", {{"calls", {1, 2, 3}}}}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  const int64_t job = SubmitStereo("timeout");
  ASSERT_TRUE(WaitForJobState(job, "failed")) << Job(job).dump(2);
  EXPECT_THAT(Job(job)["error"].get<std::string>(),
              HasSubstr("camera timed out (simulated fault, call 1)"));
  CommandResult show = Cli({"jobs", "show", std::to_string(job)});
  EXPECT_THAT(show.out, HasSubstr("camera timed out"));

  // Still serving, and the camera works again: the next capture succeeds.
  EXPECT_THAT(StatusLine("camera"), StartsWith("connected"));
  EXPECT_THAT(StatusLine("stage"), StartsWith("connected"));
  const int64_t again = SubmitStereo("after-timeout");
  EXPECT_TRUE(WaitForJobState(again, "succeeded")) << Job(again).dump(2);
  EXPECT_EQ(StopDaemon(), 0);
}

// A camera that drops and never comes back (the scene's disconnect fault
// without disconnect_failed_reopens): the capture is suspended, not failed;
// `hw status` says the camera is being reconnected and why, with a growing
// attempt count; cancel still works and leaves the rig safe; the daemon
// serves throughout and stops cleanly.
TEST_F(HardwareTest, ACameraThatNeverComesBackSuspendsTheCaptureCancelWorks) {
  nlohmann::json patch = SmallCamera();
  patch["faults"] = {{"camera", {{"disconnect", {{"calls", {2}}}}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  const int64_t job = SubmitStereo("unplugged");
  ASSERT_TRUE(WaitForJobState(job, "paused")) << Job(job).dump(2);
  // The first frame made it; the second did not and is not recorded.
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "1");
  EXPECT_EQ(
      Sql(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ", job,
                       " AND message LIKE 'suspended: camera disconnected, "
                       "reconnecting (attempt %'")),
      "1");
  EXPECT_EQ(Sql(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ",
                             job, " AND message LIKE '%the camera dropped%'")),
            "1");

  // hw status while the suspended capture holds the rig: the camera line
  // says it is being reconnected, and the attempts go on (bounded wait:
  // 0.5 + 1 + 2 s of backoff reach attempt 4).
  EXPECT_THAT(StatusLine("camera"), StartsWith("reconnecting (attempt "));
  int64_t attempt = 0;
  for (int i = 0; i < 200 && attempt < 3; ++i) {
    nlohmann::json camera = Status()["camera"];
    EXPECT_EQ(camera["state"], "DEVICE_STATE_RECONNECTING") << camera.dump();
    attempt = camera.contains("reconnect_attempt")
                  ? ::hdrstereo::testing::JsonInt(camera["reconnect_attempt"])
                  : 0;
    if (attempt < 3) absl::SleepFor(absl::Milliseconds(50));
  }
  EXPECT_GE(attempt, 3);
  EXPECT_THAT(StatusLine("camera"),
              HasSubstr("no camera found (simulated disconnect: reopen "
                        "attempt"));
  EXPECT_EQ(::hdrstereo::testing::JsonInt(Status()["camera"]["disconnects"]),
            1);
  EXPECT_EQ(Cli({"session", "list"}).exit_code, 0);

  ASSERT_EQ(Cli({"jobs", "cancel", std::to_string(job)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(job, "cancelled")) << Job(job).dump(2);
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "1");
  // The rig is free and safe: the stage answers and is idle; the camera is
  // still being reconnected, and says so.
  nlohmann::json status = Status();
  EXPECT_EQ(status["stage"]["state"], "DEVICE_STATE_CONNECTED");
  EXPECT_EQ(status["camera"]["state"], "DEVICE_STATE_RECONNECTING");
  EXPECT_EQ(StopDaemon(), 0);
}

// A camera that is not there when the daemon starts is looked for like one
// that dropped: the daemon serves and says so, a capture submitted
// meanwhile is suspended before its first frame, and it goes on once the
// camera is plugged in.
TEST_F(HardwareTest, ACameraAbsentAtTheStartIsFoundAndTheCaptureProceeds) {
  const fs::path plug = dir_ / "plug";
  nlohmann::json patch = SmallCamera();
  patch["faults"] = {{"camera", {{"absent_until_file", plug.string()}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string(),
               "--camera-reconnect-first-s", "0.05", "--camera-reconnect-max-s",
               "0.2"});
  const std::string line = StatusLine("camera");
  EXPECT_THAT(line, StartsWith("reconnecting (attempt "));
  EXPECT_THAT(line, HasSubstr("no camera found (simulated: not plugged in "
                              "until " +
                              plug.string() + " exists)"));
  nlohmann::json camera = Status()["camera"];
  EXPECT_EQ(camera["state"], "DEVICE_STATE_RECONNECTING") << camera.dump();
  EXPECT_EQ(::hdrstereo::testing::JsonInt(camera.value("disconnects", "0")), 0)
      << "never there: no drop";

  const int64_t job = SubmitStereo("late");
  ASSERT_TRUE(WaitForJobState(job, "paused")) << Job(job).dump(2);
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "0");
  EXPECT_EQ(EventsLike("suspended: camera disconnected, reconnecting "
                       "(attempt %): no camera found (simulated: not plugged "
                       "in until"),
            1);
  EXPECT_THAT(Job(job).value("suspension_reason", ""),
              HasSubstr("no camera found"));

  { std::ofstream(plug) << "plugged in\n"; }
  ASSERT_TRUE(WaitForJobState(job, "succeeded")) << Job(job).dump(2);
  ExpectConsistentStore("late", 2);
  EXPECT_EQ(EventsLike("resumed: the condition cleared (was: camera "
                       "disconnected, reconnecting"),
            1);
  EXPECT_EQ(EventsLike("dropped"), 0);
  EXPECT_THAT(StatusLine("camera"), StartsWith("connected"));
  EXPECT_EQ(StopDaemon(), 0);
}

// A real-mode daemon told of a network camera (--camera-port ptpip:...)
// that does not answer yet looks for it with backoff; once the camera is
// up (the simulated PTP/IP camera on that port) it is connected through
// libgphoto2, `hw status` names it by its address, and settings go to it.
TEST_F(HardwareTest, ANetworkCameraNotThereAtTheStartIsWaitedFor) {
  // A free loopback port for the camera that is not there yet.
  absl::StatusOr<std::vector<int>> ports = testing::FreeLoopbackPorts(1);
  ASSERT_TRUE(ports.ok()) << ports.status();
  const int port = (*ports)[0];
  StartDaemon({"--hardware", "real", "--camera-port",
               absl::StrCat("ptpip:127.0.0.1:", port), "--stage-port",
               (dir_ / "no-stage").string(), "--projector-display", ":99",
               "--camera-reconnect-first-s", "0.05", "--camera-reconnect-max-s",
               "0.2"});
  EXPECT_THAT(StatusLine("camera"), StartsWith("reconnecting (attempt "));

  sim::Scene scene = *sim::LoadBundledScene("lab-lamp");
  sim::ScaleCamera(scene, 320);
  sim::SimWorld world(scene);
  sim::PtpIpCameraOptions options;
  options.port = port;
  absl::StatusOr<std::unique_ptr<sim::PtpIpCamera>> camera =
      sim::PtpIpCamera::Start(world, options);
  ASSERT_TRUE(camera.ok()) << camera.status();
  std::string line;
  for (int i = 0; i < 100; ++i) {
    line = StatusLine("camera");
    if (absl::StartsWith(line, "connected")) break;
    absl::SleepFor(absl::Milliseconds(100));
  }
  EXPECT_THAT(
      line,
      StartsWith("connected  hdrstereo simulated camera (lab-lamp) sim-"));
  EXPECT_THAT(line, HasSubstr("  PTP/IP 127.0.0.1"));
  CommandResult set =
      Cli({"hw", "camera", "set", "--exposure", "1/40", "--iso", "400"});
  EXPECT_EQ(set.exit_code, 0) << set.out << set.err;
  EXPECT_THAT(Cli({"hw", "camera", "get"}).out, HasSubstr("1/40"));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HardwareTest, StalledStageFailsTheMoveClearlyAndTheDaemonServes) {
  nlohmann::json patch;
  patch["faults"] = {{"stage", {{"stall", {{"probability", 1.0}}}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  // 1 mm at 20 mm/s: the driver gives up after 1.5 x 0.05 s + 2 s.
  CommandResult move = Cli({"hw", "stage", "move", "1"});
  EXPECT_EQ(move.exit_code, 1) << move.err;
  EXPECT_THAT(move.err, HasSubstr("move to 1.000 mm did not finish within"));
  EXPECT_THAT(move.err, HasSubstr("is the stage stalled?"));
  EXPECT_THAT(move.err, Not(HasSubstr("did not answer within")));

  // Stopped halfway, and the daemon answers.
  EXPECT_THAT(StatusLine("stage"), StartsWith("connected  0.500 mm"));
  EXPECT_EQ(Cli({"session", "list"}).exit_code, 0);

  // When the CLI's own deadline passes first, that is what it says.
  CommandResult impatient = Cli({"--timeout", "1", "hw", "stage", "move", "2"});
  EXPECT_EQ(impatient.exit_code, 3) << impatient.err;
  EXPECT_THAT(impatient.err, HasSubstr("did not answer within 1 s"));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HardwareTest, SilentStageLeavesTheDaemonServingWithoutAStage) {
  // Every try of the driver's first command (get maxspeed) goes unanswered.
  nlohmann::json patch;
  patch["faults"] = {{"stage", {{"silent", {{"calls", {1, 2, 3}}}}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  const std::string stage = StatusLine("stage");
  EXPECT_THAT(stage, StartsWith("disconnected"));
  EXPECT_THAT(stage, HasSubstr("did not answer \"get maxspeed\""));
  EXPECT_THAT(StatusLine("camera"), StartsWith("connected"));
  EXPECT_EQ(Status()["stage"]["state"], "DEVICE_STATE_DISCONNECTED");

  CommandResult move = Cli({"hw", "stage", "move", "5"});
  EXPECT_EQ(move.exit_code, 1) << move.err;
  EXPECT_THAT(move.err, HasSubstr("no stage: "));
  // A capture needs the stage: refused with the reason, daemon still up.
  ASSERT_EQ(Cli({"session", "create", "no-stage"}).exit_code, 0);
  CommandResult capture =
      Cli({"capture", "stereo", "no-stage", "--exposures", "1/125"});
  EXPECT_NE(capture.exit_code, 0);
  EXPECT_THAT(capture.err, HasSubstr("stage"));
  EXPECT_EQ(Cli({"hw", "status"}).exit_code, 0);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HardwareTest, StageFallingSilentIsReportedAsAFault) {
  // The stage opens (call 1), then stops answering for the three tries of
  // the first status query's "get pos" (calls 2-4), then recovers.
  nlohmann::json patch;
  patch["faults"] = {{"stage", {{"silent", {{"calls", {2, 3, 4}}}}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  const std::string stage = StatusLine("stage");
  EXPECT_THAT(stage, StartsWith("fault"));
  EXPECT_THAT(stage, HasSubstr("did not answer \"get pos\""));
  EXPECT_THAT(StatusLine("stage"), StartsWith("connected  0.000 mm"));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HardwareTest, GarbledStageIsLeftOutWithTheReason) {
  nlohmann::json patch;
  patch["faults"] = {{"stage", {{"garbled", {{"probability", 1.0}}}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  const std::string stage = StatusLine("stage");
  EXPECT_THAT(stage, StartsWith("disconnected"));
  EXPECT_THAT(stage, HasSubstr("answered \"get maxspeed\" with garbage"));
  EXPECT_THAT(StatusLine("camera"), StartsWith("connected"));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HardwareTest, FaultFlagAbortsStageCommandsOnTheWire) {
  nlohmann::json patch;
  patch["faults"] = {{"stage", {{"warning_flag", "FS"}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  EXPECT_THAT(StatusLine("stage"), HasSubstr("[FS WR]"));
  CommandResult home = Cli({"hw", "stage", "home"});
  EXPECT_EQ(home.exit_code, 1) << home.err;
  EXPECT_THAT(home.err, HasSubstr("homing failed: stage reports FS (stalled"));
  CommandResult move = Cli({"hw", "stage", "move", "3"});
  EXPECT_EQ(move.exit_code, 1) << move.err;
  EXPECT_THAT(move.err, HasSubstr("move to 3.000 mm failed"));
  EXPECT_EQ(Cli({"hw", "status"}).exit_code, 0);
  EXPECT_EQ(StopDaemon(), 0);
}

}  // namespace
}  // namespace hdrstereo
