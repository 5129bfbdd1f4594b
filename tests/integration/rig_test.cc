// SPDX-License-Identifier: GPL-3.0-or-later
//
// At the rig, through the real hdrstereod (simulated hardware) and the real
// CLI: live view (frame-rate cap, statistics against the simulator's exact
// render, refused during a capture, ended by a capture that starts) and the
// projector probe (the simulated latency found within one step; refresh
// rate and latency recorded with a structured-light capture).
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hdrstereo/v1/hardware.grpc.pb.h"
#include "processing/exposure/frame_statistics.h"
#include "tests/support/camera_hold.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/subprocess.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;

constexpr double kLatencyS = 0.125;
constexpr double kRefreshHz = 75;

absl::Time TimeOf(const google::protobuf::Timestamp& t) {
  return absl::FromUnixSeconds(t.seconds()) + absl::Nanoseconds(t.nanos());
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

class RigTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  std::unique_ptr<v1::Hardware::Stub> Stub() {
    return v1::Hardware::NewStub(
        grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()));
  }

  // Reads a whole preview stream: its frames and its last message.
  struct Stream {
    std::vector<v1::PreviewFrame> frames;
    std::optional<v1::PreviewEnded> ended;
    grpc::Status status;
  };
  Stream Preview(double max_fps, int max_frames) {
    v1::StreamPreviewRequest request;
    request.set_max_fps(max_fps);
    request.set_max_frames(max_frames);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::seconds(60));
    std::unique_ptr<v1::Hardware::Stub> stub = Stub();
    auto reader = stub->StreamPreview(&context, request);
    Stream stream;
    v1::PreviewMessage message;
    while (reader->Read(&message)) {
      if (message.has_ended()) {
        stream.ended = message.ended();
      } else {
        stream.frames.push_back(message.frame());
      }
    }
    stream.status = reader->Finish();
    return stream;
  }

  // A stereo capture of one exposure into a new session; its job id.
  int64_t SubmitStereo(const std::string& session) {
    EXPECT_EQ(Cli({"session", "create", session}).exit_code, 0);
    return Submit({"capture", "stereo", session, "--exposures", "1/125",
                   "--baseline-mm", "50", "--no-ambient"});
  }

  // The small lab-lamp with a projector `latency_s` late at kRefreshHz,
  // and a camera that takes no time beyond its exposure (at time scale 1
  // only the latency and the probe's own waits take real time).
  fs::path TimedScene(double latency_s,
                      const nlohmann::json& faults = nlohmann::json::object()) {
    nlohmann::json patch = ::hdrstereo::testing::SmallLabLamp();
    if (!faults.empty()) patch["faults"] = faults;
    patch["projector"]["latency_s"] = latency_s;
    patch["projector"]["refresh_hz"] = kRefreshHz;
    patch["timing"] = {
        {"readout_s", 0}, {"transfer_s", 0}, {"projector_settle_s", 0}};
    return WriteScene("lab-lamp", patch);
  }
};

TEST_F(RigTest, PreviewFramesComeNoFasterThanTheCap) {
  StartDaemon();
  Stream four = Preview(4, 5);
  ASSERT_TRUE(four.status.ok()) << four.status.error_message();
  ASSERT_EQ(four.frames.size(), 5u);
  ASSERT_TRUE(four.ended.has_value());
  EXPECT_EQ(four.ended->reason(), "sent the 5 frames asked for");
  EXPECT_EQ(four.ended->capture_job_id(), 0);
  EXPECT_EQ(four.ended->frames(), 5);
  for (size_t i = 0; i < four.frames.size(); ++i) {
    EXPECT_EQ(four.frames[i].sequence(), static_cast<int64_t>(i + 1));
    EXPECT_EQ(four.frames[i].fps_cap(), 4);
    if (i == 0) continue;
    EXPECT_GE(TimeOf(four.frames[i].time()) - TimeOf(four.frames[i - 1].time()),
              absl::Milliseconds(250))
        << "frame " << i + 1;
  }
  // Asking for more than the daemon's maximum gets the maximum (10/s).
  Stream fast = Preview(1000, 4);
  ASSERT_TRUE(fast.status.ok()) << fast.status.error_message();
  ASSERT_EQ(fast.frames.size(), 4u);
  for (size_t i = 1; i < fast.frames.size(); ++i) {
    EXPECT_EQ(fast.frames[i].fps_cap(), 10);
    EXPECT_GE(TimeOf(fast.frames[i].time()) - TimeOf(fast.frames[i - 1].time()),
              absl::Milliseconds(100));
  }

  // Bad requests change nothing and say what to do.
  for (auto [fps, frames, wanted] :
       std::vector<std::tuple<double, int, std::string>>{
           {-1, 1, "max_fps is -1; use 0 (5 frames/s) or a positive rate"},
           {NAN, 1, "max_fps is nan"},
           {1, -2, "max_frames is -2; use 0 (until cancelled) or more"}}) {
    Stream bad = Preview(fps, frames);
    EXPECT_EQ(bad.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_THAT(bad.status.error_message(), HasSubstr(wanted));
    EXPECT_TRUE(bad.frames.empty());
  }
  EXPECT_EQ(StopDaemon(), 0);
}

// The statistics of a live-view frame of a known scene are those of the
// simulator's exact render of it (within what JPEG changes).
TEST_F(RigTest, PreviewStatisticsAreThoseOfTheExactRender) {
  StartDaemon();  // the bundled lab-lamp: 1200 x 900, previews 480 x 360
  ASSERT_EQ(Cli({"hw", "camera", "set", "--exposure", "1/30", "--iso", "100"})
                .exit_code,
            0);
  ASSERT_EQ(Cli({"hw", "projector", "blank"}).exit_code, 0);
  Stream stream = Preview(0, 1);
  ASSERT_TRUE(stream.status.ok()) << stream.status.error_message();
  ASSERT_EQ(stream.frames.size(), 1u);
  const v1::PreviewFrame& frame = stream.frames[0];
  EXPECT_EQ(frame.width_px(), 480);
  EXPECT_EQ(frame.height_px(), 360);
  EXPECT_DOUBLE_EQ(frame.exposure_s(), 1.0 / 30);

  // The exact render: stage at 0 mm, projector black, the daemon's first
  // preview.
  absl::StatusOr<sim::Scene> scene = sim::LoadBundledScene("lab-lamp");
  ASSERT_TRUE(scene.ok()) << scene.status();
  sim::SimWorld world(*scene);
  const cv::Mat black =
      cv::Mat::zeros(scene->projector.height, scene->projector.width, CV_8UC1);
  const cv::Mat exact =
      sim::RenderFrame(world.renderer(), sim::PreviewView(*scene, 0), black,
                       {.exposure_s = 1.0 / 30, .iso = 100, .aperture_f = 8},
                       sim::PreviewNoiseSeed(*scene, 0));
  absl::StatusOr<exposure::FrameStatistics> truth =
      exposure::ComputeFrameStatistics(exact);
  ASSERT_TRUE(truth.ok()) << truth.status();
  ASSERT_EQ(frame.channels_size(), 3);
  const double pixels = 480.0 * 360.0;
  for (int c = 0; c < 3; ++c) {
    const v1::ChannelStatistics& got = frame.channels(c);
    const exposure::ChannelStatistics& want = truth->channels[c];
    SCOPED_TRACE(want.name);
    EXPECT_EQ(got.channel(), want.name);
    ASSERT_EQ(got.histogram_size(), exposure::kLevels);
    // JPEG (quality 95) moves levels by a few steps, not the distribution:
    // percentiles within 2 levels, the mean within 1, the cumulative
    // histograms within 2 % of the pixels. Its half-resolution colour
    // (4:2:0) smears the saturated lamp's edges, which moves a channel's
    // clipped fractions by up to 1.5 % of the pixels (red: 0.9 %).
    EXPECT_NEAR(got.p1(), want.p1, 2);
    EXPECT_NEAR(got.p50(), want.p50, 2);
    EXPECT_NEAR(got.p99(), want.p99, 2);
    EXPECT_NEAR(got.mean(), want.mean, 1.0);
    EXPECT_NEAR(got.clipped_low(), want.clipped_low, 0.015);
    EXPECT_NEAR(got.clipped_high(), want.clipped_high, 0.015);
    double got_cumulative = 0, want_cumulative = 0, worst = 0;
    for (int v = 0; v < exposure::kLevels; ++v) {
      got_cumulative += got.histogram(v);
      want_cumulative += want.histogram[v];
      worst = std::max(worst, std::abs(got_cumulative - want_cumulative));
    }
    EXPECT_EQ(got_cumulative, pixels);
    EXPECT_LE(worst / pixels, 0.02);
  }
  // The scene's lamp saturates: the frame has clipped pixels to find (13.5 %
  // of them in red).
  EXPECT_GT(truth->channels[0].clipped_high, 0.05);

  // The CLI writes the frame and prints its statistics line.
  const fs::path out = dir_ / "preview.jpg";
  CommandResult cli = Cli({"hw", "preview", "--out", out.string()});
  ASSERT_EQ(cli.exit_code, 0) << cli.err;
  EXPECT_THAT(cli.out,
              MatchesRegex("#1 480x360 1/30 s  red p1/50/99 [0-9]+/[0-9]+/"
                           "[0-9]+ clipped [0-9.]+%/[0-9.]+%  green .*  blue "
                           ".*\n"));
  const std::string jpeg = ReadFile(out);
  const cv::Mat written =
      cv::imdecode(cv::Mat(1, static_cast<int>(jpeg.size()), CV_8UC1,
                           const_cast<char*>(jpeg.data())),
                   cv::IMREAD_COLOR);
  EXPECT_EQ(written.size(), cv::Size(480, 360));
  ExpectNoTempFiles();
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(RigTest, PreviewIsRefusedWhileACaptureHoldsTheRigNamingTheJob) {
  ::hdrstereo::testing::CameraHold hold(dir_ / "hold");
  nlohmann::json patch = ::hdrstereo::testing::SmallLabLamp();
  patch["faults"] = {
      {"camera", {{"hold", {{"calls", {1}}}}, {"hold_fifo", hold.path()}}}};
  StartDaemon({"--sim-scene", WriteScene("lab-lamp", patch).string()});
  const int64_t job = SubmitStereo("held");
  ASSERT_GT(job, 0);
  ASSERT_TRUE(hold.WaitUntilHeld(absl::Seconds(60)));

  const std::string named = absl::StrCat(
      "in use by a capture job: capture job ", job, " (session held)");
  Stream refused = Preview(0, 1);
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(refused.status.error_message(), HasSubstr(named));
  EXPECT_TRUE(refused.frames.empty());
  const fs::path out = dir_ / "preview.jpg";
  CommandResult cli = Cli({"hw", "preview", "--out", out.string()});
  EXPECT_EQ(cli.exit_code, 1) << cli.err;
  EXPECT_THAT(cli.err, HasSubstr(named));
  EXPECT_FALSE(fs::exists(out));

  hold.Release();
  ASSERT_TRUE(WaitForJobState(job, "succeeded")) << Job(job).dump(2);
  // Free again.
  EXPECT_EQ(Cli({"hw", "preview"}).exit_code, 0);
  EXPECT_EQ(StopDaemon(), 0);
}

// A capture that starts ends a running live view cleanly (the CLI says so
// and exits 0), and the capture succeeds.
TEST_F(RigTest, ACaptureThatStartsEndsLiveViewAndSucceeds) {
  StartDaemon(
      {"--sim-scene",
       WriteScene("lab-lamp", ::hdrstereo::testing::SmallLabLamp()).string()});
  const fs::path out = dir_ / "live.jpg";
  const fs::path log = dir_ / "preview.log";
  absl::StatusOr<::hdrstereo::testing::Process> cli =
      ::hdrstereo::testing::Process::Start(
          {HDRSTEREO_CLI, "--server", address_, "hw", "preview", "--watch",
           "--fps", "10", "--out", out.string()},
          log);
  ASSERT_TRUE(cli.ok()) << cli.status();
  ASSERT_TRUE(::hdrstereo::testing::WaitForFile(out, absl::Seconds(60)));

  const int64_t job = SubmitStereo("during-live-view");
  ASSERT_GT(job, 0);
  const std::optional<int> exit_code = cli->Wait(absl::Seconds(60));
  ASSERT_TRUE(exit_code.has_value());
  EXPECT_EQ(*exit_code, 0);
  const std::string printed = ReadFile(log);
  EXPECT_THAT(printed,
              HasSubstr(absl::StrCat("live view ended: capture job ", job,
                                     " (session during-live-view) started")));
  EXPECT_THAT(printed, HasSubstr("#1 240x180 "));
  ASSERT_TRUE(WaitForJobState(job, "succeeded")) << Job(job).dump(2);
  ExpectConsistentStore("during-live-view", 2);
  EXPECT_EQ(StopDaemon(), 0);
}

// The probe finds the simulated projector's latency within one step of
// its delays, through the daemon, the CLI and the simulated devices in
// real time.
TEST_F(RigTest, TheProbeFindsTheSimulatedLatencyWithinOneStep) {
  StartDaemon(
      {"--sim-scene", TimedScene(kLatencyS).string(), "--sim-time-scale", "1"});
  constexpr double kStep = 0.05;
  const nlohmann::json probe = CliJson(
      {"hw", "projector", "probe", "--step", "0.05", "--max-delay", "0.3"});
  ASSERT_TRUE(probe.contains("latency_s")) << probe.dump();
  const double latency = probe["latency_s"].get<double>();
  EXPECT_LE(std::abs(latency - kLatencyS), kStep) << probe.dump(2);
  EXPECT_DOUBLE_EQ(probe["refresh_hz"].get<double>(), kRefreshHz);
  EXPECT_LT(probe["black_level"].get<double>(),
            probe["white_level"].get<double>());
  ASSERT_FALSE(probe["frames"].empty());
  EXPECT_EQ(probe["frames"].back()["white"], true);
  // The projector is left black.
  EXPECT_EQ(CliJson({"hw", "status"})["projector"]["showing"], "blank");

  CommandResult text =
      Cli({"hw", "projector", "probe", "--step", "0.05", "--max-delay", "0.3"});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("refresh  75.00 Hz (period 13.33 ms)"));
  EXPECT_THAT(text.out, MatchesRegex("(.|\n)*latency +0\\.[0-9]+ s \\(the "
                                     "first white frame(.|\n)*"));

  // Bad options are refused, naming the field.
  CommandResult bad =
      Cli({"hw", "projector", "probe", "--step", "0.001", "--max-delay", "1"});
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_THAT(bad.err, HasSubstr("more than 100 frames"));
  EXPECT_EQ(StopDaemon(), 0);
}

// A structured-light plan with the probe step: the latency is measured
// first, every frame waits for its pattern (the white frame is lit, though
// the projector is late), and latency and refresh rate are recorded with
// the capture.
TEST_F(RigTest, AStructuredLightCaptureProbesAndRecordsTheProjectorTiming) {
  StartDaemon(
      {"--sim-scene", TimedScene(kLatencyS).string(), "--sim-time-scale", "1"});
  ASSERT_EQ(Cli({"session", "create", "sl"}).exit_code, 0);
  const int64_t job = Submit({"capture", "sl", "sl", "--exposures", "1/75",
                              "--views", "1", "--probe-projector"});
  ASSERT_GT(job, 0);
  ASSERT_TRUE(WaitForJobState(job, "succeeded", absl::Seconds(180)))
      << Job(job).dump(2);
  const double latency =
      std::stod(Sql("SELECT projector_latency_s FROM captures"));
  EXPECT_LE(std::abs(latency - kLatencyS), 0.02 + 1e-9);  // default step
  EXPECT_EQ(std::stod(Sql("SELECT projector_refresh_hz FROM captures")),
            kRefreshHz);
  // The job says both (Jobs.Get, `jobs show`).
  const nlohmann::json timing = Job(job)["projector_timing"];
  EXPECT_EQ(timing["latency_s"].get<double>(), latency) << timing.dump();
  EXPECT_EQ(timing["refresh_hz"].get<double>(), kRefreshHz);
  EXPECT_THAT(Cli({"jobs", "show", std::to_string(job)}).out,
              HasSubstr(absl::StrFormat(
                  "latency %.3f s (probed; each frame waits it), refresh "
                  "75.00 Hz",
                  latency)));
  EXPECT_EQ(EventsLike("projector latency %each frame waits that long%"), 1);
  EXPECT_EQ(EventsLike("display refresh 75.00 Hz: every exposure lasts whole "
                       "periods"),
            1);
  // The all-white frame is lit and the all-black one is not.
  auto mean_of = [&](const std::string& pattern) {
    const cv::Mat image = cv::imread(
        (data_root() / "sessions" / "sl" /
         Sql(absl::StrCat("SELECT path FROM frames WHERE pattern = '", pattern,
                          "'")))
            .string());
    return cv::mean(image)[1];
  };
  EXPECT_GT(mean_of("white"), mean_of("black") + 5);
  EXPECT_EQ(StopDaemon(), 0);
}

// A camera timeout while the latency is probed (its second frame) is a
// transient fault, as at a frame: the probe is taken again from its start
// and the capture finishes with the latency found.
TEST_F(RigTest, AProbeThatMeetsACameraTimeoutIsTakenAgain) {
  StartDaemon(
      {"--sim-scene",
       TimedScene(kLatencyS, {{"camera", {{"timeout", {{"calls", {2}}}}}}})
           .string(),
       "--sim-time-scale", "1"});
  ASSERT_EQ(Cli({"session", "create", "sl"}).exit_code, 0);
  const int64_t job = Submit({"capture", "sl", "sl", "--exposures", "1/75",
                              "--views", "1", "--probe-projector"});
  ASSERT_GT(job, 0);
  ASSERT_TRUE(WaitForJobState(job, "succeeded", absl::Seconds(180)))
      << Job(job).dump(2) << daemon_log();
  EXPECT_EQ(EventsLike("measuring the projector''s timing: %; it is measured "
                       "again (attempt 2 of at most 3)"),
            1)
      << Job(job).dump(2);
  const double latency =
      Job(job)["projector_timing"]["latency_s"].get<double>();
  EXPECT_LE(std::abs(latency - kLatencyS), 0.02 + 1e-9);
  EXPECT_EQ(StopDaemon(), 0);
}

// Without the probe: the refresh rate is still recorded (latency NULL); an
// exposure that is not a whole number of periods is warned about, or
// rounded when the plan asks.
TEST_F(RigTest, ExposuresAreCheckedAgainstTheRefreshPeriodOrRounded) {
  StartDaemon({"--sim-scene", TimedScene(0).string()});
  ASSERT_EQ(Cli({"session", "create", "warned"}).exit_code, 0);
  const int64_t warned = Submit(
      {"capture", "sl", "warned", "--exposures", "1/125", "--views", "1"});
  ASSERT_TRUE(WaitForJobState(warned, "succeeded")) << Job(warned).dump(2);
  EXPECT_EQ(EventsLike("display refresh 75.00 Hz (period 13.33 ms): "
                       "exposure(s) 0.008 s are not a whole number of "
                       "periods%--round-to-refresh%"),
            1);
  EXPECT_EQ(Sql("SELECT projector_latency_s IS NULL FROM captures"), "1");
  EXPECT_EQ(std::stod(Sql("SELECT projector_refresh_hz FROM captures")),
            kRefreshHz);
  EXPECT_FALSE(Job(warned)["projector_timing"].contains("latency_s"));
  EXPECT_THAT(Cli({"jobs", "show", std::to_string(warned)}).out,
              HasSubstr("latency not probed, refresh 75.00 Hz"));

  ASSERT_EQ(Cli({"session", "create", "rounded"}).exit_code, 0);
  const int64_t rounded =
      Submit({"capture", "sl", "rounded", "--exposures", "1/125,1/40",
              "--views", "1", "--round-to-refresh"});
  ASSERT_TRUE(WaitForJobState(rounded, "succeeded")) << Job(rounded).dump(2);
  const nlohmann::json plan = Job(rounded)["capture"]["structured_light"];
  ASSERT_EQ(plan["exposures_s"].size(), 2u) << plan.dump();
  EXPECT_DOUBLE_EQ(plan["exposures_s"][0].get<double>(), 1.0 / 75);
  EXPECT_DOUBLE_EQ(plan["exposures_s"][1].get<double>(), 2.0 / 75);
  EXPECT_EQ(Sql(absl::StrCat("SELECT count(DISTINCT exposure_s) FROM frames f "
                             "JOIN captures c ON c.id = f.capture_id WHERE "
                             "c.job_id = ",
                             rounded)),
            "2");
  EXPECT_EQ(StopDaemon(), 0);
}

}  // namespace
}  // namespace hdrstereo
