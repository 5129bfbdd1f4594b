// SPDX-License-Identifier: GPL-3.0-or-later
//
// Capture jobs end to end: the real daemon with simulated hardware (the real
// Zaber driver on the emulated controller's pty), real SQLite, real gRPC and
// the real CLI. Scenes are the bundled lab-lamp at a small resolution so the
// suite stays quick; what is checked does not depend on the size.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "hardware/sim/bundled_scenes.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"
#include "hdrstereo/v1/sessions.grpc.pb.h"
#include "processing/hdr/auto_bracket.h"
#include "processing/hdr/merge.h"
#include "tests/support/camera_hold.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/tmpfs.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::Process;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;

class CaptureTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  void StartSim(const nlohmann::json& patch = SmallLabLamp(),
                double time_scale = 0,
                const std::string& bundled = "lab-lamp") {
    scene_path_ = WriteScene(bundled, patch);
    StartDaemon({"--sim-scene", scene_path_.string(), "--sim-time-scale",
                 absl::StrCat(time_scale)});
  }

  fs::path scene_path_;
};

// Mean absolute grey difference between the left image and the right image
// sampled at x - d (the true disparity), over non-occluded pixels; with
// `shift` false the right image is sampled at x.
double WarpError(const cv::Mat& left, const cv::Mat& right,
                 const sim::ViewTruth& truth, bool shift) {
  cv::Mat l, r;
  cv::cvtColor(left, l, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right, r, cv::COLOR_BGR2GRAY);
  double sum = 0;
  int n = 0;
  for (int y = 0; y < l.rows; ++y) {
    for (int x = 0; x < l.cols; ++x) {
      const float d = truth.disparity.at<float>(y, x);
      if (!truth.nonoccluded.at<uchar>(y, x) || !std::isfinite(d)) continue;
      const int xr = static_cast<int>(std::lround(x - (shift ? d : 0)));
      if (xr < 0 || xr >= r.cols) continue;
      const uchar lv = l.at<uchar>(y, x);
      if (lv == 255 || lv < 8) continue;  // clipped: carries no position
      sum += std::abs(int(lv) - int(r.at<uchar>(y, xr)));
      ++n;
    }
  }
  return n > 0 ? sum / n : 1e9;
}

TEST_F(CaptureTest, BracketedStereoFramesRowsAndTrueDisparity) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "lab"}).exit_code, 0);
  CommandResult capture = Cli({"capture", "stereo", "lab", "--watch"});
  ASSERT_EQ(capture.exit_code, 0) << capture.out << capture.err;
  EXPECT_THAT(capture.out, HasSubstr("succeeded"));

  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "17");
  EXPECT_EQ(Sql("SELECT count(*) FROM frames WHERE view_index = 1"), "8");
  EXPECT_EQ(Sql("SELECT group_concat(DISTINCT stage_position_mm) FROM frames "
                "WHERE path LIKE '%/right/%'"),
            "150.0");
  EXPECT_EQ(Sql("SELECT count(DISTINCT exposure_s) FROM frames"), "8");
  EXPECT_EQ(Sql("SELECT width_px || 'x' || height_px FROM frames LIMIT 1"),
            "240x180");
  ExpectConsistentStore("lab", 17);

  const fs::path dir = data_root() / "sessions/lab/captures/1";
  for (const char* name :
       {"left/ambient/exp_1-250s.png", "left/stereo/exp_1-15s.png",
        "left/stereo/exp_1-2000s.png", "right/stereo/exp_1-125s.png"}) {
    EXPECT_TRUE(fs::exists(dir / name)) << name;
  }
  // The right view is the left moved by 150 mm: shifting it by the
  // simulator's exact disparity must line it up with the left view.
  absl::StatusOr<sim::Scene> scene = sim::LoadScene(scene_path_.string());
  ASSERT_TRUE(scene.ok());
  sim::SimWorld world(*scene);
  world.BlankProjector();
  absl::StatusOr<sim::StereoTruth> truth = world.Truth(0, 150);
  ASSERT_TRUE(truth.ok());
  const cv::Mat left =
      cv::imread((dir / "left/stereo/exp_1-125s.png").string());
  const cv::Mat right =
      cv::imread((dir / "right/stereo/exp_1-125s.png").string());
  const double aligned = WarpError(left, right, truth->left, true);
  const double unaligned = WarpError(left, right, truth->left, false);
  RecordProperty("aligned_grey_error", std::to_string(aligned));
  RecordProperty("unaligned_grey_error", std::to_string(unaligned));
  EXPECT_LT(aligned, 2.0) << "grey levels";
  EXPECT_LT(aligned, 0.5 * unaligned);

  // ListFrames over the wire agrees with the database.
  nlohmann::json frames = CliJson({"jobs", "show", "1"});
  EXPECT_EQ(JsonInt(frames["progress"]["done"]), 17);
}

TEST_F(CaptureTest,
       StructuredLightFramesAreEveryPatternAtEveryExposureAndView) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "sl"}).exit_code, 0);
  CommandResult capture = Cli({"capture", "sl", "sl", "--watch"});
  ASSERT_EQ(capture.exit_code, 0) << capture.err;
  // 2 views x 2 exposures x (2 x (7 + 7) + white + black).
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "120");
  EXPECT_EQ(Sql("SELECT count(*) FROM frames WHERE inverse = 1"), "56");
  EXPECT_EQ(Sql("SELECT count(*) FROM frames WHERE pattern = 'white'"), "4");
  EXPECT_EQ(Sql("SELECT count(DISTINCT pattern) FROM frames"), "16");
  EXPECT_TRUE(
      fs::exists(data_root() / "sessions/sl/captures/1/right/structured_light/"
                               "sl_row_b06_inv_exp_1-125s.png"));
  ExpectConsistentStore("sl", 120);
}

TEST_F(CaptureTest, BadPlansAreRefusedAndNothingIsQueued) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "s"}).exit_code, 0);
  CommandResult zero = Cli({"capture", "stereo", "s", "--exposures", "1/60,0"});
  EXPECT_EQ(zero.exit_code, 2);
  EXPECT_THAT(zero.err, HasSubstr("exposure"));
  CommandResult far = Cli({"capture", "stereo", "s", "--baseline-mm", "400"});
  EXPECT_EQ(far.exit_code, 2);
  EXPECT_THAT(far.err, HasSubstr("beyond the stage travel"));
  std::string many = "1/100";
  for (int i = 0; i < 64; ++i) absl::StrAppend(&many, ",1/100");
  CommandResult too_many = Cli({"capture", "sl", "s", "--exposures", many});
  EXPECT_EQ(too_many.exit_code, 2);
  EXPECT_THAT(too_many.err, HasSubstr("at most 64"));
  CommandResult unknown = Cli({"capture", "stereo", "nope"});
  EXPECT_EQ(unknown.exit_code, 4);
  EXPECT_THAT(unknown.err, HasSubstr("no session named \"nope\""));
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs"), "0");
}

TEST_F(CaptureTest, KilledDuringStructuredLightResumesWithNothingMissing) {
  // A little modelled time per frame so that kills land mid-capture.
  StartSim(SmallLabLamp(), 0.02);
  ASSERT_EQ(Cli({"session", "create", "crash"}).exit_code, 0);
  const int64_t job = Submit({"capture", "sl", "crash"});
  ASSERT_GT(job, 0);
  int kills = 0;
  for (int64_t kill_after : {5, 35, 70}) {
    const absl::Time deadline = absl::Now() + absl::Seconds(120);
    while (FramesDone(job) < kill_after && absl::Now() < deadline) {
      absl::SleepFor(absl::Milliseconds(10));
    }
    if (Job(job).value("state", "") == "JOB_STATE_SUCCEEDED") break;
    KillDaemon();
    ++kills;
    StartSim(SmallLabLamp(), 0.02);
  }
  EXPECT_GE(kills, 2) << "the capture finished before it could be killed";
  ASSERT_TRUE(WaitForJobState(job, "succeeded", absl::Seconds(300)))
      << daemon_log();
  ExpectConsistentStore("crash", 120);
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs"), "1");
  EXPECT_EQ(Sql(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ",
                             job, " AND state = 'interrupted'")),
            std::to_string(kills));
  ExpectNoTempFiles();
}

// Every channel of every pixel that is not an emitter (by the scene's
// objects, or also a lamp the bracket excluded) of both views has a sample
// in the well-exposed window of the scene's exact sensor at one of
// `exposures`: judged by the simulator's exact radiance, not the probes.
double ExactCoverage(const sim::Scene& scene,
                     const std::vector<double>& exposures) {
  sim::SimWorld world(scene);
  world.BlankProjector();  // as the bracketed capture leaves it
  absl::StatusOr<sim::StereoTruth> truth = world.Truth(0, 150);
  EXPECT_TRUE(truth.ok()) << truth.status();
  absl::StatusOr<hdr::ExposureWindow> window = hdr::WellExposedWindow(
      {scene.sensor.full_well_e, scene.sensor.read_noise_e, 0}, 40,
      hdr::MergeOptions().linear_saturation);
  EXPECT_TRUE(window.ok()) << window.status();
  const double gain =
      scene.sensor.electrons_per_exposure / scene.sensor.full_well_e;
  int64_t pixels = 0, covered = 0;
  for (const sim::ViewTruth* view : {&truth->left, &truth->right}) {
    for (int y = 0; y < view->radiance.rows; ++y) {
      for (int x = 0; x < view->radiance.cols; ++x) {
        const int id = view->object_id.at<uint16_t>(y, x);
        if (id > 0) {
          const sim::Rgb e = scene.objects[id - 1].material.emission;
          if (e[0] + e[1] + e[2] > 0) continue;
        }
        ++pixels;
        bool all = true;
        for (int c = 0; c < 3; ++c) {
          const double r = view->radiance.at<cv::Vec3f>(y, x)[c] * gain;
          all = all &&
                std::any_of(exposures.begin(), exposures.end(), [&](double t) {
                  return r * t >= window->min_signal &&
                         r * t <= window->max_signal;
                });
        }
        covered += all;
      }
    }
  }
  return static_cast<double>(covered) / pixels;
}

std::vector<double> ChosenExposures(const nlohmann::json& job) {
  std::vector<double> out;
  if (!job.contains("auto_bracket")) return out;
  for (const nlohmann::json& e : job["auto_bracket"]["exposures_s"]) {
    out.push_back(e.get<double>());
  }
  return out;
}

// `capture stereo --auto` on the bundled textured scene (a low range):
// metered, fewer exposures than the thesis' eight, recorded with the
// capture as chosen, shown by `jobs show` and in the processing report.
TEST_F(CaptureTest, AutoBracketMetersChoosesRecordsAndReports) {
  // The textured scene's own camera, at lab-lamp's small test size.
  StartSim({{"camera", SmallLabLamp()["camera"]}}, 0, "textured");
  ASSERT_EQ(Cli({"session", "create", "auto"}).exit_code, 0);
  CommandResult capture =
      Cli({"capture", "stereo", "auto", "--auto", "--watch"});
  ASSERT_EQ(capture.exit_code, 0) << capture.out << capture.err;
  EXPECT_THAT(capture.out, HasSubstr("its exposures are chosen by metering"));
  EXPECT_THAT(capture.out, HasSubstr("metering the left view: probe at"));
  EXPECT_THAT(capture.out, HasSubstr("automatic bracket: "));

  // The plan chosen, and why, as jobs show and the capture record say.
  const nlohmann::json job = Job(1);
  const std::vector<double> chosen = ChosenExposures(job);
  ASSERT_GE(chosen.size(), 2u) << job;
  // textured spans less than the eight's 1/2000 .. 1/15 s and the window.
  EXPECT_LT(chosen.size(), 8u) << job;
  EXPECT_EQ(job["state"], "JOB_STATE_SUCCEEDED") << job;
  EXPECT_EQ(job["auto_bracket"]["coverage"].get<double>(), 1.0);
  EXPECT_THAT(job["auto_bracket"]["reason"].get<std::string>(),
              HasSubstr("100.00 % of the non-emitter pixels covered"));
  EXPECT_EQ(job["auto_bracket"]["min_snr"].get<double>(), 40);
  const nlohmann::json stored =
      nlohmann::json::parse(Sql("SELECT auto_bracket FROM captures"));
  EXPECT_EQ(stored["exposures_s"].get<std::vector<double>>(), chosen);
  CommandResult show = Cli({"jobs", "show", "1"});
  EXPECT_THAT(show.out, HasSubstr(absl::StrCat(
                            "auto bracket  ", chosen.size(),
                            " exposures (the thesis' fixed bracket has 8)")));
  EXPECT_THAT(show.out, HasSubstr("scene range"));

  // The frames: the chosen exposures at both views and an ambient frame,
  // in the camera's own format again (the probes were 16-bit TIFF).
  const int frames = 2 * static_cast<int>(chosen.size()) + 1;
  ExpectConsistentStore("auto", frames);
  EXPECT_EQ(Sql("SELECT count(DISTINCT exposure_s) FROM frames WHERE path "
                "LIKE '%/stereo/%'"),
            std::to_string(chosen.size()));
  for (double e : chosen) {  // each at both views
    EXPECT_EQ(Sql(absl::StrFormat("SELECT count(*) FROM frames WHERE path LIKE "
                                  "'%%/stereo/%%' AND abs(exposure_s - %.17g) "
                                  "<= 1e-9 * %.17g",
                                  e, e)),
              "2")
        << e;
  }
  EXPECT_EQ(Sql("SELECT count(*) FROM frames WHERE path NOT LIKE '%.png'"),
            "0");
  // The probes are kept in the job's folder and are no frames.
  const fs::path probes = data_root() / "sessions/auto/jobs/1/probes";
  int probe_files = 0;
  for (const fs::directory_entry& f :
       fs::recursive_directory_iterator(probes)) {
    probe_files += f.is_regular_file();
    EXPECT_EQ(f.is_regular_file() ? f.path().extension().string() : ".tiff",
              ".tiff");
  }
  EXPECT_EQ(probe_files, job["auto_bracket"]["probes"].get<int>());
  EXPECT_TRUE(fs::exists(probes / "left") && fs::exists(probes / "right"));

  // Judged by the exact radiance: every non-emitter pixel covered.
  absl::StatusOr<sim::Scene> scene = sim::LoadScene(scene_path_.string());
  ASSERT_TRUE(scene.ok());
  EXPECT_EQ(ExactCoverage(*scene, chosen), 1.0);

  // And the session report says so.
  CommandResult process = Cli({"process", "auto", "--watch"});
  ASSERT_EQ(process.exit_code, 0) << process.out;
  const std::string report =
      ReadFileOrDie(data_root() / "sessions/auto/report/index.html");
  EXPECT_THAT(report, HasSubstr(absl::StrCat("auto bracket</th><td>",
                                             chosen.size(), " exposures: ")));
  EXPECT_THAT(report, HasSubstr("100.00 % of the non-emitter pixels"));
  EXPECT_THAT(report, HasSubstr("fixed bracket (thesis)"));
}

TEST_F(CaptureTest, AutoBracketKilledAfterMeteringResumesWithTheSameBracket) {
  // A little modelled time per frame so that the kill lands mid-capture.
  StartSim(SmallLabLamp(), 0.05);
  ASSERT_EQ(Cli({"session", "create", "resume"}).exit_code, 0);
  const int64_t job = Submit({"capture", "stereo", "resume", "--auto"});
  ASSERT_GT(job, 0);
  const absl::Time deadline = absl::Now() + absl::Seconds(120);
  while (FramesDone(job) < 4 && absl::Now() < deadline) {
    absl::SleepFor(absl::Milliseconds(10));
  }
  const nlohmann::json killed = Job(job);
  ASSERT_NE(killed.value("state", ""), "JOB_STATE_SUCCEEDED")
      << "the capture finished before it could be killed";
  const std::vector<double> before = ChosenExposures(killed);
  ASSERT_FALSE(before.empty());
  KillDaemon();
  StartSim(SmallLabLamp(), 0.05);
  ASSERT_TRUE(WaitForJobState(job, "succeeded", absl::Seconds(300)))
      << daemon_log();
  // Metered once; the resumed job took the rest with the same bracket.
  EXPECT_EQ(ChosenExposures(Job(job)), before);
  EXPECT_EQ(EventsLike("automatic bracket: "), 1);
  EXPECT_EQ(EventsLike("automatic bracket chosen before: "), 1);
  ExpectConsistentStore("resume", 2 * static_cast<int>(before.size()) + 1);
}

// The camera drops while the scene is metered (its third capture call is
// the second probe): the job suspends at that probe, the camera is
// reopened, the probe is taken again and the capture finishes with the
// bracket chosen from complete probes.
TEST_F(CaptureTest, AutoBracketLosesTheCameraWhileMeteringAndWaitsForIt) {
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = {
      {"camera",
       {{"disconnect", {{"calls", {3}}}}, {"disconnect_failed_reopens", 1}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "drop"}).exit_code, 0);
  CommandResult run = Cli({"capture", "stereo", "drop", "--auto", "--watch"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err << daemon_log();
  EXPECT_THAT(run.out, HasSubstr("suspended: camera disconnected"));
  const nlohmann::json job = Job(1);
  EXPECT_EQ(job["state"], "JOB_STATE_SUCCEEDED");
  EXPECT_EQ(
      EventsLike("metering the left view: probe at %: the camera "
                 "dropped (capturing: camera disconnected during transfer "
                 "(simulated fault, call 3)); the probe is taken again "
                 "once it is back"),
      1)
      << run.out;
  EXPECT_EQ(EventsLike("suspended: camera disconnected"), 1);
  EXPECT_EQ(EventsLike("resumed: the condition cleared"), 1);
  const std::vector<double> chosen = ChosenExposures(job);
  ASSERT_GE(chosen.size(), 2u) << job;
  EXPECT_EQ(job["auto_bracket"]["coverage"].get<double>(), 1.0);
  ExpectConsistentStore("drop", 2 * static_cast<int>(chosen.size()) + 1);
}

TEST_F(CaptureTest, AutoBracketRefusesASceneBeyondTheCameraUnlessLampsGo) {
  // A lamp at 2e6 cd/m^2 saturates even at 1/8000 s.
  nlohmann::json patch = SmallLabLamp();
  absl::StatusOr<sim::Scene> bundled = sim::LoadBundledScene("lab-lamp");
  ASSERT_TRUE(bundled.ok());
  const int lamp = bundled->FindObject("lamp");
  ASSERT_GE(lamp, 0);
  nlohmann::json objects;
  for (const sim::BundledScene& s : sim::BundledScenes()) {
    if (s.name == "lab-lamp") {
      objects = nlohmann::json::parse(std::string(s.json)).at("objects");
    }
  }
  objects[lamp]["material"]["emission"] = {2e6, 1.8e6, 1.4e6};
  patch["objects"] = objects;
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "bright"}).exit_code, 0);

  // Bad requests first: refused before anything is queued.
  CommandResult both =
      Cli({"capture", "stereo", "bright", "--auto", "--exposures", "1/15"});
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_THAT(both.err, HasSubstr("excludes"));
  CommandResult low =
      Cli({"capture", "stereo", "bright", "--auto", "--min-snr", "5"});
  EXPECT_EQ(low.exit_code, 2);
  EXPECT_THAT(low.err, HasSubstr("bracketed_stereo.auto_bracket.min_snr is 5; "
                                 "it must be in [10, 1000]"));
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs"), "0");

  // The lamp cannot be covered: the job fails before any frame, with both
  // ranges and the uncovered fraction.
  CommandResult refused =
      Cli({"capture", "stereo", "bright", "--auto", "--watch"});
  EXPECT_EQ(refused.exit_code, 1) << refused.out;
  const std::string error = Job(1)["error"].get<std::string>();
  EXPECT_THAT(error, HasSubstr("the scene's range exceeds what the camera "
                               "offers: the scene spans at least"));
  EXPECT_THAT(error, HasSubstr("stops (1/8000 s .. 30 s, samples at SNR >= "
                               "40"));
  EXPECT_THAT(error, HasSubstr("too bright even at 1/8000 s"));
  EXPECT_THAT(error, HasSubstr("exclude_emitters_above"));
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "0");
  EXPECT_EQ(Sql("SELECT auto_bracket FROM captures"), "");

  // Excluding the lamp: covered, and the lamp's pixels are reported.
  CommandResult excluded = Cli({"capture", "stereo", "bright", "--auto",
                                "--exclude-emitters-above", "100", "--watch"});
  ASSERT_EQ(excluded.exit_code, 0) << excluded.out;
  const nlohmann::json job = Job(2);
  absl::StatusOr<sim::Scene> scene = sim::LoadScene(scene_path_.string());
  ASSERT_TRUE(scene.ok());
  sim::SimWorld world(*scene);
  absl::StatusOr<sim::StereoTruth> truth = world.Truth(0, 150);
  ASSERT_TRUE(truth.ok());
  const int lamp_pixels = cv::countNonZero(truth->left.object_id == lamp + 1) +
                          cv::countNonZero(truth->right.object_id == lamp + 1);
  ASSERT_GT(lamp_pixels, 0);
  EXPECT_EQ(JsonInt(job["auto_bracket"]["emitter_pixels"]), lamp_pixels);
  EXPECT_EQ(job["auto_bracket"]["coverage"].get<double>(), 1.0);
  EXPECT_EQ(ExactCoverage(*scene, ChosenExposures(job)), 1.0);
  const std::string frames = Sql("SELECT count(*) FROM frames");

  // Too short a longest exposure for the dark walls: refused as well, with
  // the remedy that applies (the lamp is excluded already).
  CommandResult dark =
      Cli({"capture", "stereo", "bright", "--auto", "--exclude-emitters-above",
           "100", "--max-exposure", "1/4000", "--watch"});
  EXPECT_EQ(dark.exit_code, 1) << dark.out;
  const std::string too_dark = Job(3)["error"].get<std::string>();
  EXPECT_THAT(too_dark, HasSubstr("the scene's range exceeds what the camera "
                                  "offers"));
  EXPECT_THAT(too_dark, HasSubstr("(1/8000 s .. 1/4000 s, samples at SNR"));
  EXPECT_THAT(too_dark, HasSubstr("too dark even at 1/4000 s"));
  EXPECT_THAT(too_dark, HasSubstr("llow longer exposures (max_exposure_s)"));
  EXPECT_THAT(too_dark, ::testing::Not(HasSubstr("exclude_emitters_above")));
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), frames);
}

TEST_F(CaptureTest, PauseResumeAndCancelLeaveTheRigSafe) {
  StartSim(SmallLabLamp(), 0.05);
  ASSERT_EQ(Cli({"session", "create", "p"}).exit_code, 0);
  const int64_t job = Submit({"capture", "sl", "p"});
  const absl::Time deadline = absl::Now() + absl::Seconds(60);
  while (FramesDone(job) < 3 && absl::Now() < deadline) {
    absl::SleepFor(absl::Milliseconds(10));
  }
  ASSERT_EQ(Cli({"jobs", "pause", std::to_string(job)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(job, "paused"));
  const int64_t paused_at = FramesDone(job);
  absl::SleepFor(absl::Milliseconds(500));
  EXPECT_EQ(FramesDone(job), paused_at) << "frames taken while paused";
  // While paused, the hardware still belongs to the job.
  CommandResult move = Cli({"hw", "stage", "move", "10"});
  EXPECT_EQ(move.exit_code, 1);
  EXPECT_THAT(move.err, HasSubstr("in use by a capture job"));

  ASSERT_EQ(Cli({"jobs", "resume", std::to_string(job)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(job, "running"));
  ASSERT_EQ(Cli({"jobs", "cancel", std::to_string(job)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(job, "cancelled"));
  EXPECT_GT(FramesDone(job), paused_at);
  // The rig is free again and idle; frames taken so far are kept intact.
  nlohmann::json status = CliJson({"hw", "status"});
  EXPECT_EQ(status["stage"]["state"], "DEVICE_STATE_CONNECTED");
  ExpectConsistentStore("p", std::stoi(Sql("SELECT count(*) FROM frames")));
  EXPECT_EQ(Cli({"jobs", "cancel", std::to_string(job)}).exit_code, 1);
}

TEST_F(CaptureTest, ConcurrentAndLateWatchersSeeTheSameHistory) {
  StartSim(SmallLabLamp(), 0.01);
  ASSERT_EQ(Cli({"session", "create", "w"}).exit_code, 0);
  const int64_t job = Submit({"capture", "stereo", "w"});
  std::vector<Process> watchers;
  for (int i = 0; i < 2; ++i) {
    absl::StatusOr<Process> watcher =
        Process::Start({HDRSTEREO_CLI, "--server", address_, "jobs", "watch",
                        std::to_string(job)},
                       dir_ / absl::StrCat("watch", i, ".log"));
    ASSERT_TRUE(watcher.ok());
    watchers.push_back(*std::move(watcher));
  }
  for (Process& watcher : watchers) {
    std::optional<int> code = watcher.Wait(absl::Seconds(120));
    ASSERT_TRUE(code.has_value());
    EXPECT_EQ(*code, 0);
  }
  const std::string first = ReadFileOrDie(dir_ / "watch0.log");
  const std::string second = ReadFileOrDie(dir_ / "watch1.log");
  EXPECT_THAT(first, HasSubstr("17/17"));
  EXPECT_THAT(first, HasSubstr("succeeded"));
  // Not a terminal: one line per event, the same events for both.
  EXPECT_EQ(first, second);

  CommandResult late = Cli({"jobs", "watch", std::to_string(job)});
  EXPECT_EQ(late.exit_code, 0);
  EXPECT_EQ(late.out, first) << "a late watcher replays the whole history";
}

// A camera that times out at every attempt at frame 5 (calls 6, 7, 8): the
// job fails naming each attempt, keeps the frames before, and the same plan
// submitted again takes only the missing ones.
TEST_F(CaptureTest, AFaultAtEveryAttemptFailsTheJobNamingEachAndAResubmitEnds) {
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = {{"camera", {{"timeout", {{"calls", {6, 7, 8}}}}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "f"}).exit_code, 0);
  CommandResult first = Cli({"capture", "stereo", "f", "--watch"});
  EXPECT_EQ(first.exit_code, 1);
  nlohmann::json failed = Job(1);
  EXPECT_EQ(failed["state"], "JOB_STATE_FAILED");
  EXPECT_THAT(
      failed.value("error", ""),
      HasSubstr(" failed 3 times: 1) capturing: camera timed out (simulated "
                "fault, call 6); 2) capturing: camera timed out (simulated "
                "fault, call 7); 3) capturing: camera timed out (simulated "
                "fault, call 8); nothing was recorded for it"));
  // Two warnings that took the frame again, and the failure: three device
  // errors.
  EXPECT_EQ(EventsLike("the frame is taken again from its start (attempt 2 "
                       "of at most 3)"),
            1);
  EXPECT_EQ(EventsLike("the frame is taken again from its start (attempt 3 "
                       "of at most 3)"),
            1);
  EXPECT_EQ(EventsOfKind("camera_timeout"), 3);
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "5");
  ExpectConsistentStore("f", 5);

  CommandResult again = Cli({"capture", "stereo", "f", "--watch"});
  ASSERT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_THAT(again.out, HasSubstr("resuming: 5 frames already recorded"));
  EXPECT_EQ(Sql("SELECT count(*) FROM captures"), "1");
  ExpectConsistentStore("f", 17);
  EXPECT_EQ(ExpectFilesMatchTheirRows("f"), 17);
}

// A fault that does not pass by itself (an exposure the camera does not
// offer) fails the job at once, naming the frame, the step and the error.
TEST_F(CaptureTest, APermanentDeviceFaultFailsTheFrameAtOnce) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "p"}).exit_code, 0);
  EXPECT_EQ(Cli({"capture", "stereo", "p", "--exposures", "1/16000",
                 "--no-ambient", "--watch"})
                .exit_code,
            1);
  const nlohmann::json failed = Job(1);
  EXPECT_EQ(failed["state"], "JOB_STATE_FAILED");
  EXPECT_THAT(failed.value("error", ""),
              HasSubstr("frame left view, stereo, 1-16000s: setting the "
                        "exposure to 1-16000s: exposure 6.25e-05 s is outside "
                        "the simulated camera's [0.000125, 30] s; not tried "
                        "again: this fault does not pass by itself; nothing "
                        "was recorded for it"));
  EXPECT_EQ(EventsLike("taken again"), 0);
  EXPECT_EQ(EventsOfKind("camera_error"), 1);
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "0");
  ExpectNoTempFiles();
}

// A transient device fault in the middle of a frame: the frame is taken
// again from its start at the same boundary (one warning, counted as the
// device error it is; a fault flag also suspends the job until the stage
// shows it no more) and every frame is recorded once.
struct TransientFault {
  std::string name;
  nlohmann::json faults;        // the scene's
  std::string plan;             // "stereo" (17 frames) or "sl" (120)
  std::string warning;          // LIKE pattern of the warning that retakes
  std::string kind;             // the device error kind it counts as
  std::string suspension = "";  // LIKE pattern of its suspension, if any
};

void PrintTo(const TransientFault& fault, std::ostream* os) {
  *os << fault.name;
}

class TransientFaultCaptureTest
    : public CaptureTest,
      public ::testing::WithParamInterface<TransientFault> {};

TEST_P(TransientFaultCaptureTest, TheFrameIsTakenAgainAndRecordedOnce) {
  const TransientFault& fault = GetParam();
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = fault.faults;
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "t"}).exit_code, 0);
  CommandResult run = Cli({"capture", fault.plan, "t", "--watch"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err << daemon_log();
  const int frames = fault.plan == "sl" ? 120 : 17;
  EXPECT_EQ(JsonInt(Job(1)["progress"]["done"]), frames);
  EXPECT_EQ(EventsLike(fault.warning), 1)
      << Sql("SELECT group_concat(message, '\n') FROM job_events");
  EXPECT_EQ(EventsLike("(attempt "), 1);
  EXPECT_EQ(EventsOfKind(fault.kind), 1);
  EXPECT_EQ(Sql("SELECT count(*) FROM job_events WHERE kind != ''"), "1");
  EXPECT_EQ(EventsLike("suspended: "), fault.suspension.empty() ? 0 : 1);
  if (!fault.suspension.empty()) {
    EXPECT_EQ(EventsLike(fault.suspension), 1);
    EXPECT_EQ(EventsLike("resumed: the condition cleared"), 1);
  }
  ExpectConsistentStore("t", frames);
  EXPECT_EQ(ExpectFilesMatchTheirRows("t"), frames);
}

// The stereo capture's stage commands, with the simulated time at 0 (every
// move ends by the first status poll): 1 "get maxspeed", 2-3 the job's
// State(); frame 0: its conditions' State() 4-5, Home() ("home" 6, a poll
// 7), MoveTo(0) (State() 8-9, "move abs" 10, a poll 11); frames 1-8: the
// conditions' State() from 12; frame 9, the right view: State() 28-29,
// MoveTo(150) (State() 30-31, "move abs" 32, a poll 33); frames 10-16: State()
// 34-47; parking: MoveTo(0) (State() 48-49, "move abs" 50). The Zaber driver
// sends a command three times before its garbled or missing reply reaches
// the daemon.
INSTANTIATE_TEST_SUITE_P(
    DeviceFaults, TransientFaultCaptureTest,
    ::testing::Values(
        TransientFault{
            "StageGarbledOnAMove",
            {{"stage", {{"garbled", {{"calls", {32, 33, 34}}}}}}},
            "stereo",
            "frame right view, %: moving the stage to 150.000 mm: stage on % "
            "answered \"move abs %\" with garbage%; the stage is homed again "
            "and the frame is taken again from its start (attempt 2 of at "
            "most 3)",
            "stage_garbled"},
        TransientFault{
            "StageGarbledOnTheHoming",
            {{"stage", {{"garbled", {{"calls", {6, 7, 8}}}}}}},
            "stereo",
            "frame left view, %: homing the stage: stage on % answered "
            "\"home\" with garbage%; the stage is homed again and the frame is "
            "taken again from its start (attempt 2 of at most 3)",
            "stage_garbled"},
        TransientFault{
            "StageSilentOnAMove",
            {{"stage", {{"silent", {{"calls", {32, 33, 34}}}}}}},
            "stereo",
            "frame right view, %: moving the stage to 150.000 mm: stage on % "
            "did not answer \"move abs %\" within 500ms (3 tries); the stage "
            "is homed again and the frame is taken again from its start",
            "stage_silent"},
        TransientFault{
            "StageStallsOnAMove",
            {{"stage", {{"stall", {{"calls", {10}}}}}}},
            "stereo",
            "frame left view, %: moving the stage to 0.000 mm: move to 0.000 "
            "mm did not finish within 2s (target 0.000 mm, stopped at 0.000 "
            "mm); is the stage stalled?; the stage is homed again",
            "stage_stalled"},
        TransientFault{
            "StageFaultFlagOnAMove",
            {{"stage",
              {{"warning_window",
                {{"calls", {33}}, {"lasts", 4}, {"flag", "FS"}}}}}},
            "stereo",
            "frame right view, %: moving the stage to 150.000 mm: move to "
            "150.000 mm failed: stage reports FS %; the stage is homed again",
            "stage_flag",
            "suspended: the stage reports warning flags FS"},
        TransientFault{
            "StageGarbledWhileParking",
            {{"stage", {{"garbled", {{"calls", {50, 51, 52}}}}}}},
            "stereo",
            "parking the rig after the last frame: moving the stage to 0.000 "
            "mm: stage on % answered \"move abs 0\" with garbage%; the stage "
            "is homed again and it is parked again (attempt 2 of at most 3)",
            "stage_garbled"},
        TransientFault{
            "CameraTimeout",
            {{"camera", {{"timeout", {{"calls", {6}}}}}}},
            "stereo",
            "frame left view, %: capturing: camera timed out (simulated "
            "fault, call 6); the frame is taken again from its start (attempt "
            "2 of at most 3)",
            "camera_timeout"},
        // The simulated camera retries "busy" 5 times, like the driver.
        TransientFault{"CameraBusyPastTheDriversRetries",
                       {{"camera", {{"busy_first_calls", 6}}}},
                       "stereo",
                       "frame left view, %: capturing: camera busy (simulated "
                       "fault, call 6); the frame is taken again from its "
                       "start (attempt 2 of at most 3)",
                       "camera_busy"},
        // Lost for the one Show only: the projector checks fine right
        // after, so this is no suspension.
        TransientFault{
            "ProjectorShowFailsOnce",
            {{"projector", {{"lost", {{"calls", {40}}, {"lasts", 1}}}}}},
            "sl",
            "frame % view, pattern %: showing pattern %: projector lost "
            "(simulated fault%; the frame is taken again from its start "
            "(attempt 2 of at most 3)",
            "projector_error"}),
    [](const ::testing::TestParamInfo<TransientFault>& info) {
      return info.param.name;
    });

// The camera drops in the middle of a structured-light sequence and comes
// back after two failed reopens: the job suspends at that frame, the
// camera is reconnected (with backoff) without a restart, the job resumes
// by itself and retakes the frame that was lost; at the end every planned
// frame is there exactly once and verified against its file.
TEST_F(CaptureTest,
       StructuredLightLosesTheCameraSuspendsReconnectsAndFinishes) {
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = {
      {"camera",
       {{"disconnect", {{"calls", {40}}}}, {"disconnect_failed_reopens", 2}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "drop"}).exit_code, 0);
  CommandResult run = Cli({"capture", "sl", "drop", "--watch"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err << daemon_log();
  EXPECT_THAT(run.out, HasSubstr("suspended: camera disconnected"));
  EXPECT_THAT(run.out, HasSubstr("resumed: "));

  const nlohmann::json job = Job(1);
  EXPECT_EQ(job["state"], "JOB_STATE_SUCCEEDED");
  EXPECT_EQ(JsonInt(job["progress"]["total"]), 120);
  EXPECT_EQ(JsonInt(job["progress"]["done"]), 120);
  // One drop, one suspension, one resumption, in that order.
  EXPECT_EQ(EventsLike("the camera dropped (camera disconnected during "
                       "transfer (simulated fault, call 40))"),
            1);
  EXPECT_EQ(EventsLike("suspended: camera disconnected, reconnecting "
                       "(attempt 1): camera disconnected during transfer"),
            1);
  EXPECT_EQ(EventsLike("resumed: the condition cleared (was: camera "
                       "disconnected, reconnecting (attempt "),
            1);
  EXPECT_EQ(EventsLike("suspended: "), 1);
  EXPECT_EQ(Sql("SELECT count(*) FROM job_events WHERE job_id = 1 AND "
                "message LIKE 'suspended: %' AND sequence < (SELECT "
                "min(sequence) FROM job_events WHERE job_id = 1 AND message "
                "LIKE 'resumed: %')"),
            "1");

  // Sessions.ListFrames over the wire: every frame of the plan exactly once.
  auto channel =
      grpc::CreateChannel(address_, grpc::InsecureChannelCredentials());
  auto sessions = v1::Sessions::NewStub(channel);
  std::set<int> sequences;
  int listed = 0;
  std::string token;
  for (int page = 0; page < 100; ++page) {
    v1::ListFramesRequest request;
    request.set_session("drop");
    request.mutable_page()->set_page_size(50);
    request.mutable_page()->set_page_token(token);
    v1::ListFramesResponse response;
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::seconds(30));
    grpc::Status status = sessions->ListFrames(&context, request, &response);
    ASSERT_TRUE(status.ok()) << status.error_message();
    for (const v1::Frame& frame : response.frames()) {
      ++listed;
      EXPECT_TRUE(sequences.insert(frame.sequence()).second)
          << "frame " << frame.sequence() << " twice";
      EXPECT_TRUE(frame.has_camera_exposure_s()) << frame.path();
      EXPECT_FALSE(frame.camera_file_name().empty()) << frame.path();
    }
    token = response.next_page_token();
    if (token.empty()) break;
  }
  EXPECT_EQ(listed, 120);
  ASSERT_EQ(sequences.size(), 120u);
  EXPECT_EQ(*sequences.begin(), 0);
  EXPECT_EQ(*sequences.rbegin(), 119);
  // Files and rows agree, no orphans, every file's EXIF matches its row.
  ExpectConsistentStore("drop", 120);
  EXPECT_EQ(ExpectFilesMatchTheirRows("drop"), 120);
  // The camera is back and says how often it dropped.
  nlohmann::json camera = CliJson({"hw", "status"})["camera"];
  EXPECT_EQ(camera["state"], "DEVICE_STATE_CONNECTED");
  EXPECT_EQ(JsonInt(camera["disconnects"]), 1);
}

// The suspenders other than the camera's and the disk's: a condition the
// simulator raises in the middle of a structured-light capture and lets go
// of by itself a few seconds later (fault windows counted in device calls;
// the daemon asks again every second).
class SuspenderTest : public CaptureTest {
 protected:
  struct Suspension {
    int64_t job_id = 0;
    std::vector<std::string> messages;  // every event message, in order
    nlohmann::json job;                 // `jobs show --json` while suspended
    std::string show;                   // `jobs show` while suspended
    std::string list;                   // `jobs list` while suspended
  };

  // Runs a structured-light capture in session "s" with `faults` in the
  // scene and `flags` for the daemon, following its events (Jobs.Watch)
  // until it ends; at its first suspension, reads the job with the CLI
  // while the condition still holds.
  Suspension CaptureThroughACondition(const nlohmann::json& faults,
                                      const std::vector<std::string>& flags) {
    nlohmann::json patch = SmallLabLamp();
    patch["faults"] = faults;
    scene_path_ = WriteScene("lab-lamp", patch);
    std::vector<std::string> args = {"--sim-scene", scene_path_.string()};
    args.insert(args.end(), flags.begin(), flags.end());
    StartDaemon(args);
    Suspension seen;
    EXPECT_EQ(Cli({"session", "create", "s"}).exit_code, 0);
    const int64_t id = Submit({"capture", "sl", "s"});
    EXPECT_GT(id, 0);
    seen.job_id = id;
    auto jobs = v1::Jobs::NewStub(
        grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::seconds(300));
    v1::WatchJobRequest request;
    request.set_job_id(id);
    auto stream = jobs->Watch(&context, request);
    v1::JobEvent event;
    while (stream->Read(&event)) {
      if (event.message().empty()) continue;  // progress
      seen.messages.push_back(event.message());
      if (absl::StartsWith(event.message(), "suspended: ") &&
          seen.job.is_null()) {
        const std::string job_id = std::to_string(id);
        seen.job = Job(id);
        seen.show = Cli({"jobs", "show", job_id}).out;
        seen.list = Cli({"jobs", "list"}).out;
      }
    }
    EXPECT_TRUE(stream->Finish().ok());
    return seen;
  }

  // What every such capture must show: one suspension naming `reason`
  // (seen in the Job while it held), one resumption, every planned frame
  // exactly once, and the job succeeded with nothing left suspended.
  void ExpectSuspendedAndResumed(const Suspension& seen,
                                 const std::string& reason) {
    int suspended = 0;
    int resumed = 0;
    for (const std::string& message : seen.messages) {
      suspended += absl::StartsWith(message, "suspended: ");
      resumed += absl::StartsWith(message, "resumed: ");
    }
    EXPECT_EQ(suspended, 1) << absl::StrJoin(seen.messages, "\n");
    EXPECT_EQ(resumed, 1) << absl::StrJoin(seen.messages, "\n");
    EXPECT_EQ(EventsLike(absl::StrCat("suspended: ", reason)), 1);
    EXPECT_EQ(EventsLike(absl::StrCat("resumed: the condition cleared (was: ",
                                      reason)),
              1);
    // While it held: paused, mid-capture, the reason in the Job.
    EXPECT_EQ(seen.job.value("state", ""), "JOB_STATE_PAUSED");
    EXPECT_THAT(seen.job.value("suspension_reason", ""), HasSubstr(reason));
    const int64_t done_then = JsonInt(seen.job["progress"]["done"]);
    EXPECT_GT(done_then, 0);
    EXPECT_LT(done_then, 120);
    EXPECT_THAT(seen.show, HasSubstr(absl::StrCat("suspended     ", reason)));
    EXPECT_THAT(seen.list, HasSubstr(absl::StrCat("suspended: ", reason)));
    // At the end: every frame once, nothing suspended any more.
    const nlohmann::json job = Job(seen.job_id);
    EXPECT_EQ(job["state"], "JOB_STATE_SUCCEEDED");
    EXPECT_EQ(JsonInt(job["progress"]["done"]), 120);
    EXPECT_EQ(job.value("suspension_reason", "?"), "");
    ExpectConsistentStore("s", 120);
  }
};

// The camera battery falls below --min-battery-percent for six readings
// (one per frame boundary, then one per second while suspended).
TEST_F(SuspenderTest, LowCameraBatterySuspendsAndResumesByItself) {
  const Suspension seen = CaptureThroughACondition(
      {{"camera",
        {{"low_battery", {{"calls", {30}}, {"lasts", 6}, {"percent", 12}}}}}},
      {"--min-battery-percent", "20"});
  ExpectSuspendedAndResumed(
      seen, "the camera battery is at 12%, below --min-battery-percent 20%");
}

// The stage raises a warning (WH, temperature high) on twelve replies: the
// capture waits at the next frame boundary, then re-homes and goes on.
TEST_F(SuspenderTest, StageWarningFlagSuspendsAndResumesByItself) {
  const Suspension seen = CaptureThroughACondition(
      {{"stage",
        {{"warning_window",
          {{"calls", {120}}, {"lasts", 12}, {"flag", "WH"}}}}}},
      {});
  ExpectSuspendedAndResumed(seen, "the stage reports warning flags WH");
}

// The projector is lost on the 40th pattern: that Show fails, the frame is
// not taken, the capture waits until the projector is back and shows the
// pattern again; no frame is missing or taken twice.
TEST_F(SuspenderTest, ProjectorLostSuspendsAndTheFrameIsRetaken) {
  const Suspension seen = CaptureThroughACondition(
      {{"projector", {{"lost", {{"calls", {40}}, {"lasts", 8}}}}}}, {});
  ExpectSuspendedAndResumed(seen, "the projector is lost: projector lost");
  EXPECT_EQ(EventsLike("the projector was lost (projector lost (simulated "
                       "fault"),
            1);
  EXPECT_EQ(EventsLike("the frame is taken again once it is back"), 1);
}

TEST_F(CaptureTest, CorruptTransferIsCaughtNotStored) {
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = {{"camera", {{"corrupt", {{"calls", {3}}}}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "c"}).exit_code, 0);
  EXPECT_EQ(Cli({"capture", "stereo", "c", "--watch"}).exit_code, 1);
  nlohmann::json failed = Job(1);
  EXPECT_EQ(failed["state"], "JOB_STATE_FAILED");
  EXPECT_THAT(failed.value("error", ""), HasSubstr("arrived corrupt"));
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "2");
  ExpectConsistentStore("c", 2);
  ASSERT_EQ(Cli({"capture", "stereo", "c", "--watch"}).exit_code, 0);
  ExpectConsistentStore("c", 17);
}

TEST_F(CaptureTest, EveryFrameRecordsWhatTheCameraReported) {
  StartSim();
  ASSERT_EQ(Cli({"session", "create", "v"}).exit_code, 0);
  ASSERT_EQ(Cli({"capture", "stereo", "v", "--watch"}).exit_code, 0);
  EXPECT_EQ(ExpectFilesMatchTheirRows("v"), 17);
  EXPECT_EQ(Sql("SELECT count(*) FROM frames WHERE camera_time_ms IS NULL OR "
                "aperture_f IS NULL OR camera_file_name = ''"),
            "0");
  EXPECT_EQ(EventsLike("taking it again"), 0);
}

// The faults that corrupt a dataset without any error: each one fires once,
// is caught by the frame check, and the frame is taken again; the capture
// then holds exactly the planned frames, each exposed as its row says.
TEST_F(CaptureTest, SilentCameraFaultsAreCaughtAndTheFrameRetaken) {
  const std::pair<const char*, const char*> faults[] = {
      {"previous_file", "already taken in this capture"},
      {"wrong_exposure", "not the 1/"},
      {"card_target", "on its card, not in RAM"}};
  for (const auto& [fault, message] : faults) {
    SCOPED_TRACE(fault);
    nlohmann::json patch = SmallLabLamp();
    patch["faults"] = {{"camera", {{fault, {{"calls", {5}}}}}}};
    StartSim(patch);
    const std::string session = absl::StrCat("s-", fault);
    ASSERT_EQ(Cli({"session", "create", session}).exit_code, 0);
    CommandResult run = Cli({"capture", "stereo", session, "--watch"});
    EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
    EXPECT_THAT(run.out, HasSubstr(message));
    EXPECT_EQ(EventsLike(message), 1);
    ExpectConsistentStore(session, 17);
    EXPECT_EQ(ExpectFilesMatchTheirRows(session), 17);
    StopDaemon();
  }
}

TEST_F(CaptureTest, AFaultOnTheRetakeTooFailsTheFrameNamingBothValues) {
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = {{"camera", {{"wrong_exposure", {{"calls", {4, 5}}}}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "w"}).exit_code, 0);
  EXPECT_EQ(Cli({"capture", "stereo", "w", "--watch"}).exit_code, 1);
  nlohmann::json failed = Job(1);
  EXPECT_EQ(failed["state"], "JOB_STATE_FAILED");
  const std::string error = failed.value("error", "");
  EXPECT_THAT(error, HasSubstr("failed verification twice"));
  // Both values: the camera's (twice the set time) and the one set.
  EXPECT_THAT(error, HasSubstr("not the 1/"));
  EXPECT_THAT(error, HasSubstr("nothing was recorded for it"));
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "3");
  ExpectConsistentStore("w", 3);
  EXPECT_EQ(ExpectFilesMatchTheirRows("w"), 3);
}

// The disk guard on a real small filesystem: a tmpfs of a few MB mounted as
// the data root (CI runs as root; elsewhere the test says why it skips).
class DiskGuardTest : public CaptureTest {
 protected:
  void SetUp() override {
    tmpfs_.emplace(data_root(), kSizeBytes);
    if (!tmpfs_->mounted()) GTEST_SKIP() << tmpfs_->error();
  }
  void TearDown() override {
    if (daemon_.has_value()) StopDaemon();
    tmpfs_.reset();
  }
  void StartSmall(const std::string& frame_guess_mb,
                  const std::string& margin_mb = "0", double time_scale = 0,
                  const nlohmann::json& patch = SmallLabLamp()) {
    scene_path_ = WriteScene("lab-lamp", patch);
    StartDaemon({"--sim-scene", scene_path_.string(), "--disk-margin-mb",
                 margin_mb, "--frame-bytes-guess-mb", frame_guess_mb,
                 "--sim-time-scale", absl::StrCat(time_scale)});
  }
  // Fills the filesystem until `leave` bytes are free.
  void FillLeaving(int64_t leave) {
    const nlohmann::json info = CliJson({"status"});
    const int64_t free = JsonInt(info["data_root_free_bytes"]);
    ASSERT_GT(free, leave);
    std::ofstream filler(data_root() / "filler", std::ios::binary);
    filler << std::string(free - leave, 'x');
    ASSERT_TRUE(filler.good());
  }

  static constexpr int64_t kSizeBytes = 24 << 20;
  std::optional<::hdrstereo::testing::TmpfsMount> tmpfs_;
};

TEST_F(DiskGuardTest, ACaptureThatCannotFitIsRefusedWithBothNumbers) {
  StartSmall("1");  // 17 frames of 1 MB, twice with processing: 34 MB
  ASSERT_EQ(Cli({"session", "create", "d"}).exit_code, 0);
  const nlohmann::json info = CliJson({"status"});
  const int64_t free = JsonInt(info["data_root_free_bytes"]);
  EXPECT_GT(free, 0);
  EXPECT_LE(free, kSizeBytes);
  CommandResult refused = Cli({"capture", "stereo", "d"});
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_THAT(refused.err, HasSubstr("not enough disk space"));
  EXPECT_THAT(refused.err, HasSubstr("this capture needs about 35.7 MB"));
  EXPECT_THAT(refused.err, HasSubstr("MB free"));
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs"), "0");
}

// Once a capture of a kind is on disk its real frame size is used: the
// stereo frames of this scene are far smaller than the 1 MB guess.
TEST_F(DiskGuardTest, TheLastCaptureOfTheSameKindSetsTheEstimate) {
  StartSmall("0");
  ASSERT_EQ(Cli({"session", "create", "d"}).exit_code, 0);
  ASSERT_EQ(Cli({"capture", "stereo", "d", "--watch"}).exit_code, 0);
  ASSERT_EQ(Sql("SELECT count(*) FROM frames"), "17");
  StopDaemon();
  // With the 1 MB guess this plan did not fit (test above); measured from
  // the capture on disk, the same plan fits now.
  StartSmall("1");
  const int64_t job = Submit({"capture", "stereo", "d"});
  EXPECT_GT(job, 0);
  ASSERT_TRUE(WaitForJobState(job, "succeeded"));
  const nlohmann::json info = CliJson({"status"});
  EXPECT_EQ(JsonInt(info["pending_capture_bytes"]), 0);
}

// The rest of the plan does not fit: the job is suspended at a frame
// boundary, before a write fails, with a reason that names the free space
// and what the rest needs (the frames not yet written at the capture's
// largest frame so far, and the margin); what was recorded stays intact (no
// file without its row, no row without its file, no temporary file); once
// space is freed it resumes by itself and takes only the missing frames.
TEST_F(DiskGuardTest, TheRestOfThePlanNotFittingSuspendsAndResumesByItself) {
  // A 1 MB margin: what the database needs to record the job's events.
  StartSmall("0", "1");
  ASSERT_EQ(Cli({"session", "create", "full"}).exit_code, 0);
  FillLeaving(2 << 20);  // far less than 120 frames
  const int64_t job = Submit({"capture", "sl", "full"});
  ASSERT_GT(job, 0);
  ASSERT_TRUE(WaitForJobState(job, "paused")) << daemon_log();
  const int recorded = std::stoi(Sql("SELECT count(*) FROM frames"));
  EXPECT_GT(recorded, 0);
  EXPECT_LT(recorded, 120);
  ExpectConsistentStore("full", recorded);
  ExpectNoTempFiles();
  // Both numbers: the frames not written x the largest frame + the margin.
  int64_t largest = 0;
  for (const auto& entry :
       fs::recursive_directory_iterator(data_root() / "sessions" / "full")) {
    if (entry.is_regular_file()) {
      largest = std::max(largest, static_cast<int64_t>(entry.file_size()));
    }
  }
  const int64_t left = 120 - recorded;
  const std::string reason =
      Sql("SELECT message FROM job_events WHERE message LIKE 'suspended: %'");
  EXPECT_THAT(reason, HasSubstr("suspended: disk has "));
  EXPECT_THAT(
      reason,
      HasSubstr(absl::StrCat(
          "free on the data root ", data_root().string(),
          ", the rest of the plan needs ",
          absl::StrFormat("%.1f MB", (left * largest + (1 << 20)) / 1e6), " (",
          left, " frames of ", absl::StrFormat("%.0f kB", largest / 1e3),
          " and a 1.0 MB margin)")));
  EXPECT_EQ(EventsLike("suspended: "), 1);
  // A person cannot resume into the condition; it says why.
  CommandResult resume = Cli({"jobs", "resume", std::to_string(job)});
  EXPECT_NE(resume.exit_code, 0);
  EXPECT_THAT(resume.err, HasSubstr("suspended by a condition"));
  fs::remove(data_root() / "filler");
  ASSERT_TRUE(WaitForJobState(job, "succeeded")) << daemon_log();
  EXPECT_EQ(EventsLike("resumed: the condition cleared"), 1);
  ExpectConsistentStore("full", 120);
}

// Space taken between the frame boundary's check and the frame's write (by
// another process): the write itself finds the disk full. To make that
// moment certain, the simulated camera is held (its hold fault, a FIFO) in
// the capture call of one frame, after that boundary's checks passed; the
// test fills the disk then and releases the camera, so that this frame's
// write hits ENOSPC. (A filler started on a job event would race the
// capture: the check and the write are microseconds apart.) The job is
// suspended, not failed, naming the full disk; nothing half-written is
// left; once the filler is removed the same frame is taken again and the
// capture finishes with every frame once.
TEST_F(DiskGuardTest, ENOSPCInTheWriteSuspendsAndTakesTheSameFrameAgain) {
  constexpr int kHeld = 40;  // camera call 40: the frame of sequence 39
  ::hdrstereo::testing::CameraHold hold(dir_ / "hold");
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = {
      {"camera",
       {{"hold", {{"calls", {kHeld}}}}, {"hold_fifo", hold.path().string()}}}};
  StartSmall("0", "1", 0, patch);
  ASSERT_EQ(Cli({"session", "create", "nospace"}).exit_code, 0);
  const int64_t job = Submit({"capture", "sl", "nospace"});
  ASSERT_GT(job, 0);
  ASSERT_TRUE(hold.WaitUntilHeld(absl::Seconds(120))) << daemon_log();
  // The frame before was being written while the camera was taken: let it
  // be recorded, so that the space goes before the held frame's write only.
  const std::string before = std::to_string(kHeld - 1);
  const absl::Time deadline = absl::Now() + absl::Seconds(60);
  while (Sql("SELECT count(*) FROM frames") != before &&
         absl::Now() < deadline) {
    absl::SleepFor(absl::Milliseconds(10));
  }
  ASSERT_EQ(Sql("SELECT count(*) FROM frames"), before);
  int64_t smallest = kSizeBytes;
  for (const auto& entry :
       fs::recursive_directory_iterator(data_root() / "sessions" / "nospace")) {
    if (entry.is_regular_file()) {
      smallest = std::min(smallest, static_cast<int64_t>(entry.file_size()));
    }
  }
  FillLeaving(smallest / 2);  // room for the database, not for a frame
  hold.Release();
  ASSERT_TRUE(WaitForJobState(job, "paused")) << daemon_log();

  // Nothing half-written: no temporary file, no file without its row, no row
  // without its file; the held frame has neither.
  ExpectNoTempFiles();
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), before);
  ExpectConsistentStore("nospace", kHeld - 1);
  EXPECT_EQ(EventsLike("suspended: frame % was not stored: disk full (ENOSPC): "
                       "cannot write %: No space left on device; % bytes free "
                       "on its filesystem; disk has %, the rest of the plan "
                       "needs %"),
            1);
  EXPECT_EQ(EventsLike("it is taken again once there is room"), 1);
  EXPECT_EQ(Sql(absl::StrCat("SELECT state FROM jobs WHERE id = ", job)),
            "paused");

  fs::remove(data_root() / "filler");
  ASSERT_TRUE(WaitForJobState(job, "succeeded")) << daemon_log();
  EXPECT_EQ(EventsLike("resumed: the condition cleared (was: frame "), 1);
  ExpectConsistentStore("nospace", 120);
  ExpectNoTempFiles();
  // The frame whose write failed is the one recorded at its place now.
  const std::string held_path =
      Sql(absl::StrCat("SELECT path FROM frames WHERE sequence = ", kHeld - 1));
  EXPECT_EQ(EventsLike(absl::StrCat(
                "cannot write ",
                (data_root() / "sessions" / "nospace" / held_path).string(),
                ": No space left on device")),
            3);  // the warning, the suspension and the resumption
}

// A condition that goes true while one job is paused by a person and
// another waits: the next job starts into it and is suspended before its
// first frame; it resumes once the condition clears.
TEST_F(DiskGuardTest, TheNextJobDoesNotCaptureIntoATrueCondition) {
  StartSmall("0", "1", 0.05);
  ASSERT_EQ(Cli({"session", "create", "two"}).exit_code, 0);
  const int64_t first = Submit({"capture", "sl", "two"});
  const absl::Time deadline = absl::Now() + absl::Seconds(60);
  while (FramesDone(first) < 2 && absl::Now() < deadline) {
    absl::SleepFor(absl::Milliseconds(10));
  }
  ASSERT_EQ(Cli({"jobs", "pause", std::to_string(first)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(first, "paused"));
  const int64_t second = Submit({"capture", "stereo", "two"});
  ASSERT_GT(second, 0);
  FillLeaving(512 << 10);  // less than the 1 MB margin
  ASSERT_EQ(Cli({"jobs", "cancel", std::to_string(first)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(second, "paused")) << daemon_log();
  EXPECT_EQ(FramesDone(second), 0) << "a frame was taken into a full disk";
  EXPECT_EQ(Sql(absl::StrCat("SELECT count(*) FROM job_events WHERE job_id = ",
                             second, " AND message LIKE 'suspended: %'")),
            "1");
  fs::remove(data_root() / "filler");
  ASSERT_TRUE(WaitForJobState(second, "succeeded")) << daemon_log();
  EXPECT_EQ(FramesDone(second), 17);
}

// Suspended by a condition, then paused by a person: when the condition
// clears the job stays paused (the person's pause is never auto-resumed)
// until they resume it.
TEST_F(DiskGuardTest, APersonsPauseOutlastsTheCondition) {
  StartSmall("0", "1");
  ASSERT_EQ(Cli({"session", "create", "both"}).exit_code, 0);
  FillLeaving(2 << 20);
  const int64_t job = Submit({"capture", "sl", "both"});
  ASSERT_TRUE(WaitForJobState(job, "paused")) << daemon_log();
  ASSERT_EQ(Cli({"jobs", "pause", std::to_string(job)}).exit_code, 0);
  const int64_t held = FramesDone(job);
  fs::remove(data_root() / "filler");
  const absl::Time deadline = absl::Now() + absl::Seconds(30);
  while (EventsLike("stays paused by the operator") == 0 &&
         absl::Now() < deadline) {
    absl::SleepFor(absl::Milliseconds(50));
  }
  ASSERT_EQ(EventsLike("stays paused by the operator"), 1) << daemon_log();
  absl::SleepFor(absl::Milliseconds(500));
  EXPECT_EQ(Job(job)["state"], "JOB_STATE_PAUSED");
  EXPECT_EQ(FramesDone(job), held) << "frames taken under a person's pause";
  EXPECT_EQ(EventsLike("resumed: the condition cleared"), 0);
  ASSERT_EQ(Cli({"jobs", "resume", std::to_string(job)}).exit_code, 0);
  ASSERT_TRUE(WaitForJobState(job, "succeeded")) << daemon_log();
  ExpectConsistentStore("both", 120);
}

// A condition that flaps (space freed and taken again, several times, while
// the capture runs): every suspension is followed by its resumption, and the
// capture ends with every frame exactly once.
TEST_F(DiskGuardTest, AFlappingConditionLosesNothing) {
  StartSmall("0", "1", 0.02);
  ASSERT_EQ(Cli({"session", "create", "flap"}).exit_code, 0);
  const int64_t job = Submit({"capture", "sl", "flap"});
  ASSERT_GT(job, 0);
  int flaps = 0;
  for (int i = 0; i < 4; ++i) {
    if (Job(job).value("state", "") == "JOB_STATE_SUCCEEDED") break;
    FillLeaving(512 << 10);  // less than the 1 MB margin
    if (!WaitForJobState(job, "paused", absl::Seconds(30))) break;
    ++flaps;
    absl::SleepFor(absl::Milliseconds(300 * (i % 2)));
    fs::remove(data_root() / "filler");
    ASSERT_TRUE(WaitForJobState(job, "running", absl::Seconds(30)) ||
                Job(job).value("state", "") == "JOB_STATE_SUCCEEDED")
        << daemon_log();
  }
  fs::remove(data_root() / "filler");
  EXPECT_GE(flaps, 2) << "the capture finished before the disk could flap";
  ASSERT_TRUE(WaitForJobState(job, "succeeded", absl::Seconds(300)))
      << daemon_log();
  EXPECT_EQ(EventsLike("suspended: "), flaps);
  EXPECT_EQ(EventsLike("resumed: the condition cleared"), flaps);
  ExpectConsistentStore("flap", 120);
}

}  // namespace
}  // namespace hdrstereo
