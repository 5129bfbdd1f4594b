// SPDX-License-Identifier: GPL-3.0-or-later
//
// Automatic bracketing end to end (fixture: capture_fixture.h): `capture
// stereo --auto` meters the scene, chooses, records and reports its bracket,
// keeps it across a restart, waits for a camera lost while metering, and
// refuses a scene the camera cannot cover, naming both ranges.
#include "processing/hdr/auto_bracket.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "hardware/sim/bundled_scenes.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "processing/hdr/merge.h"
#include "tests/integration/capture_fixture.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;

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
  // The simulated camera's own format is 8-bit PNG: 2/3-stop steps.
  EXPECT_EQ(job["capture"]["bracketed_stereo"]["auto_bracket"]["max_step_stops"]
                .get<double>(),
            2.0 / 3)
      << job;
  for (size_t i = 1; i < chosen.size(); ++i) {
    EXPECT_LE(std::log2(chosen[i - 1] / chosen[i]), 2.0 / 3 + 1e-6) << job;
  }
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
  // The bracket in the camera's format: the direct camera's 8-bit PNG, or
  // the one format a PTP/IP camera delivers (ptpip:tiff16 to meter).
  const char* frame_pattern =
      testing::TestSimCamera() == "ptpip:tiff16" ? "%.tiff" : "%.png";
  EXPECT_EQ(Sql(absl::StrCat("SELECT count(*) FROM frames WHERE path NOT "
                             "LIKE '",
                             frame_pattern, "'")),
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
  EXPECT_EQ(EventsLike(absl::StrCat(
                "metering the left view: probe at %: the camera dropped "
                "(capturing: ",
                testing::TestsThroughPtpIp()
                    ? "capture: the network camera at % closed the connection "
                      "(disconnected) (%)"
                    : "camera disconnected during transfer (simulated fault, "
                      "call 3)",
                "); the probe is taken again once it is back")),
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
  CommandResult fine =
      Cli({"capture", "stereo", "bright", "--auto", "--max-step", "0.1"});
  EXPECT_EQ(fine.exit_code, 2);
  EXPECT_THAT(fine.err,
              HasSubstr("bracketed_stereo.auto_bracket.max_step_stops is 0.1"));
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

}  // namespace
}  // namespace hdrstereo
