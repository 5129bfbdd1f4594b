// SPDX-License-Identifier: GPL-3.0-or-later
//
// Capture jobs end to end (fixture: capture_fixture.h): bracketed stereo
// and structured light, bad plans, a crash mid-capture, pause, resume and
// cancel, watchers, a camera lost and reconnected, and every frame checked
// against what the camera reported.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "absl/strings/str_cat.h"
#include "hardware/sim/scene.h"
#include "hardware/sim/sim_world.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"
#include "hdrstereo/v1/sessions.grpc.pb.h"
#include "tests/integration/capture_fixture.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::Process;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;

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

// Jobs.EstimateCapture: a known plan's frames, duration and disk need,
// counted by hand with the daemon's frame guess (no capture on disk yet),
// and a bad plan refused in SubmitCapture's own words; nothing is queued.
TEST_F(CaptureTest, EstimateCaptureCountsAPlanAndRefusesItAsSubmitDoes) {
  scene_path_ = WriteScene("lab-lamp", SmallLabLamp());
  StartDaemon({"--sim-scene", scene_path_.string(), "--sim-time-scale", "0",
               "--frame-bytes-guess-mb", "1", "--disk-margin-mb", "2"});
  ASSERT_EQ(Cli({"session", "create", "s"}).exit_code, 0);
  auto jobs = v1::Jobs::NewStub(
      grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()));
  v1::EstimateCaptureRequest request;
  request.set_session("s");
  v1::BracketedStereoPlan* plan =
      request.mutable_plan()->mutable_bracketed_stereo();
  plan->add_exposures_s(0.5);
  plan->add_exposures_s(0.25);
  plan->set_baseline_mm(50);
  plan->set_settle_s(1);
  {
    grpc::ClientContext context;
    v1::CaptureEstimate estimate;
    const grpc::Status s = jobs->EstimateCapture(&context, request, &estimate);
    ASSERT_TRUE(s.ok()) << s.error_message();
    // An ambient frame and 2 exposures at each of 2 views.
    EXPECT_EQ(estimate.frames(), 5);
    // 5 frames of the 1 MiB guess, as much again for processing, and the
    // 2 MiB margin.
    EXPECT_EQ(estimate.disk_bytes(), int64_t{5 * 2 + 2} << 20);
    // 1.75 s of exposure, 5 x 1 s of readout and transfer, 50 mm at
    // 20 mm/s and 1 s of settling (ExpectedSeconds).
    EXPECT_DOUBLE_EQ(estimate.duration_s(), 10.25);
    EXPECT_FALSE(estimate.exposures_chosen_at_rig());
  }
  {
    // Automatic bracketing: the default bracket's 1 + 8 x 2 frames.
    v1::EstimateCaptureRequest metered = request;
    metered.set_session("");  // none chosen yet
    metered.mutable_plan()->mutable_bracketed_stereo()->clear_exposures_s();
    metered.mutable_plan()->mutable_bracketed_stereo()->mutable_auto_bracket();
    grpc::ClientContext context;
    v1::CaptureEstimate estimate;
    const grpc::Status s = jobs->EstimateCapture(&context, metered, &estimate);
    ASSERT_TRUE(s.ok()) << s.error_message();
    EXPECT_EQ(estimate.frames(), 17);
    EXPECT_EQ(estimate.disk_bytes(), int64_t{17 * 2 + 2} << 20);
    EXPECT_TRUE(estimate.exposures_chosen_at_rig());
  }
  plan->add_exposures_s(0);
  grpc::ClientContext estimate_context;
  v1::CaptureEstimate estimate;
  const grpc::Status refused =
      jobs->EstimateCapture(&estimate_context, request, &estimate);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(refused.error_message(),
            "bracketed_stereo.exposures_s[2] is 0 s; exposures must be in "
            "(0, 3600] s");
  v1::SubmitCaptureRequest submit;
  submit.set_session("s");
  *submit.mutable_plan() = request.plan();
  grpc::ClientContext submit_context;
  v1::Job job;
  const grpc::Status also_refused =
      jobs->SubmitCapture(&submit_context, submit, &job);
  EXPECT_EQ(also_refused.error_code(), refused.error_code());
  EXPECT_EQ(also_refused.error_message(), refused.error_message());
  // A session that is given is named as SubmitCapture names it.
  v1::EstimateCaptureRequest misnamed;
  misnamed.set_session("a b");
  misnamed.mutable_plan()->mutable_calibration()->set_poses(2);
  grpc::ClientContext misnamed_context;
  const grpc::Status bad_name =
      jobs->EstimateCapture(&misnamed_context, misnamed, &estimate);
  EXPECT_EQ(bad_name.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(bad_name.error_message(),
            "session \"a b\" contains ' '; use only letters, digits, '-' and "
            "'_'");
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
  // One drop, one suspension, one resumption, in that order. Through
  // libgphoto2 the drop is the network camera closing its connection.
  const std::string dropped =
      testing::TestsThroughPtpIp()
          ? "closed the connection (disconnected)"
          : "camera disconnected during transfer (simulated fault, call 40)";
  EXPECT_EQ(EventsLike(absl::StrCat("the camera dropped (%", dropped, "%)")),
            1);
  EXPECT_EQ(EventsLike(absl::StrCat("suspended: camera disconnected, "
                                    "reconnecting (attempt 1): %",
                                    dropped, "%")),
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

// A camera that sends another bit depth than the format asked (16-bit
// PNG for the simulated camera's 8-bit PNG) is not taken at its word: the
// job fails naming both, and nothing of that frame is kept.
TEST_F(CaptureTest, AFrameOfAnotherBitDepthFailsTheJobNamingBoth) {
  nlohmann::json patch = SmallLabLamp();
  patch["faults"] = {{"camera", {{"wrong_depth", {{"calls", {3}}}}}}};
  StartSim(patch);
  ASSERT_EQ(Cli({"session", "create", "d"}).exit_code, 0);
  EXPECT_EQ(Cli({"capture", "stereo", "d", "--watch"}).exit_code, 1);
  nlohmann::json failed = Job(1);
  EXPECT_EQ(failed["state"], "JOB_STATE_FAILED");
  EXPECT_THAT(failed.value("error", ""),
              HasSubstr("decodes to CV_16UC3 pixels, but its format png8 is "
                        "8-bit; set the camera to the format the capture "
                        "asks for"));
  EXPECT_EQ(Sql("SELECT count(*) FROM frames"), "2");
  ExpectConsistentStore("d", 2);
  EXPECT_EQ(ExpectFilesMatchTheirRows("d"), 2);
  ExpectNoTempFiles();
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
    // A generic PTP camera has no capture target to switch.
    if (testing::TestsThroughPtpIp() && std::string(fault) == "card_target") {
      continue;
    }
    SCOPED_TRACE(fault);
    nlohmann::json patch = SmallLabLamp();
    patch["faults"] = {{"camera", {{fault, {{"calls", {5}}}}}}};
    StartSim(patch);
    const std::string session = absl::StrCat("s-", fault);
    ASSERT_EQ(Cli({"session", "create", session}).exit_code, 0);
    CommandResult run = Cli({"capture", "stereo", session, "--watch"});
    EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
    EXPECT_THAT(run.out, HasSubstr(message));
    EXPECT_EQ(EventsLike(message), 1)
        << Sql("SELECT group_concat(message, '\n') FROM job_events");
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

}  // namespace
}  // namespace hdrstereo
