// SPDX-License-Identifier: GPL-3.0-or-later
//
// The disk guard (fixture: capture_fixture.h) on a real small filesystem.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tests/integration/capture_fixture.h"
#include "tests/support/camera_hold.h"
#include "tests/support/tmpfs.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;

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
  // Room for the database's next transactions (its WAL grows a few 4 kB
  // pages with each), not for a frame: the held frame's size is checked at
  // the end to be above it.
  const int64_t room = smallest - (8 << 10);
  FillLeaving(room);
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
  EXPECT_GT(static_cast<int64_t>(fs::file_size(data_root() / "sessions" /
                                               "nospace" / held_path)),
            room)
      << "the held frame would have fit: the test did not fill the disk";
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
