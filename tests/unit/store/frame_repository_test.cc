// SPDX-License-Identifier: GPL-3.0-or-later
//
// FrameRepository on a real SQLite store: a job's capture found again when
// the job resumes, a resubmitted plan continuing the capture of a failed or
// cancelled job, frames recorded inside a transaction, read back in order
// and in pages, and rows whose kind or format is unknown refused.
#include "daemon/store/frame_repository.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "daemon/store/database.h"
#include "daemon/store/job_repository.h"
#include "tests/support/status_matchers.h"
#include "tests/support/store_fixture.h"

namespace hdrstereo::store {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

class FrameRepositoryTest : public testing::StoreTest {
 protected:
  // Records `n` frames (sequence 0..n-1, alternating views) of `capture`.
  void Record(const CaptureRecord& capture, int n) {
    FrameRepository frames(*store_);
    Transaction tx(store_->db());
    ASSERT_OK(tx.status());
    for (int i = 0; i < n; ++i) {
      FrameRecord f;
      f.capture_id = capture.id;
      f.sequence = i;
      f.view_index = i % 2;
      f.exposure_s = 1.0 / (15 << i);
      f.format = hardware::ImageFormat::kPng8;
      f.path = "captures/" + std::to_string(capture.id) + "/f" +
               std::to_string(i) + ".png";
      f.sha256 = "sha" + std::to_string(i);
      f.camera_time_ms = 1000 + i;
      ASSERT_OK(frames.InsertLocked(f));
    }
    ASSERT_OK(tx.Commit());
  }
};

TEST_F(FrameRepositoryTest, AJobFindsItsCaptureAgain) {
  ASSERT_OK(Session("lab").status());
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab"));
  FrameRepository frames(*store_);
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord first,
      frames.CaptureForJob(job.id, io::CaptureKind::kStructuredLight, "plan"));
  EXPECT_EQ(first.kind, io::CaptureKind::kStructuredLight);
  EXPECT_EQ(first.job_id, job.id);
  EXPECT_EQ(first.plan, "plan");
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord again,
      frames.CaptureForJob(job.id, io::CaptureKind::kStructuredLight, "plan"));
  EXPECT_EQ(again.id, first.id);
  EXPECT_EQ(again.kind, io::CaptureKind::kStructuredLight);
  EXPECT_THAT(frames.CaptureForJob(9999, io::CaptureKind::kCalibration, "p"),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("9999")));
}

// A structured-light capture records its projector's timing; a capture
// that never did reads as unknown.
TEST_F(FrameRepositoryTest, ProjectorTimingIsRecordedWithTheCapture) {
  ASSERT_OK(Session("lab").status());
  FrameRepository frames(*store_);
  ASSERT_OK_AND_ASSIGN(const JobRecord sl_job, Job("lab"));
  ASSERT_OK_AND_ASSIGN(const JobRecord stereo_job, Job("lab"));
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord sl,
      frames.CaptureForJob(sl_job.id, io::CaptureKind::kStructuredLight, "a"));
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord stereo,
      frames.CaptureForJob(stereo_job.id, io::CaptureKind::kBracketedStereo,
                           "b"));
  ASSERT_OK(frames.SetProjectorTiming(
      sl.id, {.latency_s = 0.08, .refresh_hz = 59.94}));
  ASSERT_OK_AND_ASSIGN(ProjectorTiming timing, frames.ProjectorTimingOf(sl.id));
  EXPECT_EQ(timing.latency_s, 0.08);
  EXPECT_EQ(timing.refresh_hz, 59.94);
  ASSERT_OK_AND_ASSIGN(timing, frames.ProjectorTimingOf(stereo.id));
  EXPECT_EQ(timing.latency_s, std::nullopt);
  EXPECT_EQ(timing.refresh_hz, std::nullopt);

  // Not probed, refresh unknown: both NULL again.
  ASSERT_OK(frames.SetProjectorTiming(sl.id, {}));
  ASSERT_OK_AND_ASSIGN(timing, frames.ProjectorTimingOf(sl.id));
  EXPECT_EQ(timing.latency_s, std::nullopt);
  EXPECT_EQ(timing.refresh_hz, std::nullopt);
  EXPECT_THAT(
      frames.SetProjectorTiming(9999, {}),
      StatusIs(absl::StatusCode::kNotFound, HasSubstr("no capture 9999")));
  EXPECT_THAT(
      frames.ProjectorTimingOf(9999),
      StatusIs(absl::StatusCode::kNotFound, HasSubstr("no capture 9999")));
}

TEST_F(FrameRepositoryTest, AResubmittedPlanContinuesTheEarlierCapture) {
  ASSERT_OK(Session("lab").status());
  FrameRepository frames(*store_);
  JobRepository jobs(*store_);
  ASSERT_OK_AND_ASSIGN(const JobRecord failed, Job("lab"));
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord capture,
      frames.CaptureForJob(failed.id, io::CaptureKind::kBracketedStereo,
                           "plan A"));
  Record(capture, 3);
  ASSERT_OK(
      jobs.SetState(failed.id, JobState::kFailed, "camera gone").status());

  // The same plan again: the capture (and its three frames) moves to the
  // new job.
  ASSERT_OK_AND_ASSIGN(const JobRecord retry, Job("lab"));
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord continued,
      frames.CaptureForJob(retry.id, io::CaptureKind::kBracketedStereo,
                           "plan A"));
  EXPECT_EQ(continued.id, capture.id);
  EXPECT_EQ(continued.job_id, retry.id);
  ASSERT_OK_AND_ASSIGN(const std::vector<FrameRecord> kept,
                       frames.FramesOfCapture(capture.id));
  EXPECT_EQ(kept.size(), 3u);

  // Another plan, or a plan whose job succeeded, starts a new capture.
  ASSERT_OK_AND_ASSIGN(const JobRecord other, Job("lab"));
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord fresh,
      frames.CaptureForJob(other.id, io::CaptureKind::kBracketedStereo,
                           "plan B"));
  EXPECT_NE(fresh.id, capture.id);
  ASSERT_OK(jobs.SetState(retry.id, JobState::kSucceeded, "done").status());
  ASSERT_OK_AND_ASSIGN(const JobRecord third, Job("lab"));
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord after_success,
      frames.CaptureForJob(third.id, io::CaptureKind::kBracketedStereo,
                           "plan A"));
  EXPECT_NE(after_success.id, capture.id);
  ASSERT_OK_AND_ASSIGN(const std::vector<CaptureRecord> all,
                       frames.CapturesOfSession("lab"));
  EXPECT_EQ(all.size(), 3u);
}

TEST_F(FrameRepositoryTest, TheAutomaticBracketStaysWithItsCapture) {
  ASSERT_OK(Session("lab").status());
  FrameRepository frames(*store_);
  JobRepository jobs(*store_);
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab"));
  EXPECT_THAT(
      frames.AutoBracketOfJob(job.id),
      StatusIs(absl::StatusCode::kNotFound, HasSubstr("has no capture")));
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord capture,
      frames.CaptureForJob(job.id, io::CaptureKind::kBracketedStereo, "auto"));
  EXPECT_EQ(capture.auto_bracket, "");
  ASSERT_OK_AND_ASSIGN(const std::string none, frames.AutoBracketOfJob(job.id));
  EXPECT_EQ(none, "");
  ASSERT_OK(frames.SetAutoBracket(capture.id, R"({"exposures_s":[0.1]})"));
  ASSERT_OK_AND_ASSIGN(const std::string chosen,
                       frames.AutoBracketOfJob(job.id));
  EXPECT_EQ(chosen, R"({"exposures_s":[0.1]})");
  EXPECT_THAT(frames.SetAutoBracket(9999, "{}"),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("9999")));
  // Found again by the job, continued by a resubmission, listed.
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord again,
      frames.CaptureForJob(job.id, io::CaptureKind::kBracketedStereo, "auto"));
  EXPECT_EQ(again.auto_bracket, chosen);
  ASSERT_OK(jobs.SetState(job.id, JobState::kFailed, "camera gone").status());
  ASSERT_OK_AND_ASSIGN(const JobRecord retry, Job("lab"));
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord continued,
      frames.CaptureForJob(retry.id, io::CaptureKind::kBracketedStereo,
                           "auto"));
  EXPECT_EQ(continued.id, capture.id);
  EXPECT_EQ(continued.auto_bracket, chosen);
  ASSERT_OK_AND_ASSIGN(const std::vector<CaptureRecord> all,
                       frames.CapturesOfSession("lab"));
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(all[0].auto_bracket, chosen);
}

TEST_F(FrameRepositoryTest, FramesReadBackInOrderAndInPages) {
  ASSERT_OK(Session("lab").status());
  ASSERT_OK(Session("empty").status());
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab"));
  FrameRepository frames(*store_);
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord capture,
      frames.CaptureForJob(job.id, io::CaptureKind::kBracketedStereo, "p"));
  Record(capture, 5);
  ASSERT_OK_AND_ASSIGN(const std::vector<FrameRecord> all,
                       frames.FramesOfCapture(capture.id));
  ASSERT_EQ(all.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(all[i].sequence, i);
    EXPECT_EQ(all[i].capture_kind, io::CaptureKind::kBracketedStereo);
    EXPECT_EQ(all[i].format, hardware::ImageFormat::kPng8);
    EXPECT_EQ(all[i].view_index, i % 2);
    EXPECT_EQ(all[i].camera_time_ms, 1000 + i);
  }
  ASSERT_OK_AND_ASSIGN(const std::vector<FrameRecord> page,
                       frames.FramesOfSession("lab", 0, all[1].id, 2));
  ASSERT_EQ(page.size(), 2u);
  EXPECT_EQ(page[0].sequence, 2);
  EXPECT_TRUE(frames.FramesOfSession("lab", capture.id + 1, 0, 10)->empty());
  EXPECT_TRUE(frames.CapturesOfSession("empty")->empty());
  EXPECT_THAT(frames.FramesOfSession("nope", 0, 0, 10),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("nope")));
  EXPECT_THAT(frames.CapturesOfSession("nope"),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("nope")));

  ASSERT_OK(frames.Delete(all[0].id));
  EXPECT_EQ(frames.FramesOfCapture(capture.id)->size(), 4u);
}

TEST_F(FrameRepositoryTest, RowsWithUnknownNamesAreDataLoss) {
  ASSERT_OK(Session("lab").status());
  ASSERT_OK_AND_ASSIGN(const JobRecord job, Job("lab"));
  FrameRepository frames(*store_);
  ASSERT_OK_AND_ASSIGN(
      const CaptureRecord capture,
      frames.CaptureForJob(job.id, io::CaptureKind::kCalibration, "p"));
  Record(capture, 1);
  ASSERT_OK(store_->db().Exec("UPDATE frames SET format = 'gif'"));
  EXPECT_THAT(frames.FramesOfCapture(capture.id),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("\"gif\"")));
  // captures.kind cannot hold an unknown name: the schema checks it.
  EXPECT_THAT(store_->db().Exec("UPDATE captures SET kind = 'panorama'"),
              StatusIs(absl::StatusCode::kAlreadyExists,
                       HasSubstr("CHECK constraint failed")));
  EXPECT_EQ(frames.CapturesOfSession("lab")->front().kind,
            io::CaptureKind::kCalibration);
}

}  // namespace
}  // namespace hdrstereo::store
