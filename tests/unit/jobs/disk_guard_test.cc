// SPDX-License-Identifier: GPL-3.0-or-later
//
// The disk guard's arithmetic with exact numbers: the per-frame estimate
// (the capture's own largest frame, else the last capture of the same kind,
// else the guess), what the rest of a running capture needs and the reason
// that names both numbers, and the rule that a frame boundary does not count
// the space promised to unfinished captures. The real filesystem cases are
// DiskGuardTest in tests/integration/disk_guard_test.cc.
#include "daemon/jobs/disk_guard.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "daemon/jobs/capture_plan.h"
#include "daemon/store/database.h"
#include "daemon/store/frame_repository.h"
#include "daemon/store/job_repository.h"
#include "hdrstereo/v1/jobs.pb.h"
#include "tests/support/status_matchers.h"
#include "tests/support/store_fixture.h"

namespace hdrstereo::jobs {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

TEST(FrameSizeEstimateTest, TheCapturesOwnLargestFrameReplacesTheEstimate) {
  FrameSizeEstimate size{.before_first = int64_t{32} << 20};  // the guess
  EXPECT_EQ(size.bytes(), 33'554'432);
  size.Delivered(180'000);  // measured beats guessed, also when smaller
  EXPECT_EQ(size.bytes(), 180'000);
  size.Delivered(120'000);
  EXPECT_EQ(size.bytes(), 180'000);
  size.Delivered(250'000);
  EXPECT_EQ(size.bytes(), 250'000);
  // Resumed after a restart: the frames recorded before count.
  const FrameSizeEstimate resumed{.before_first = int64_t{32} << 20,
                                  .largest_so_far = 200'000};
  EXPECT_EQ(resumed.bytes(), 200'000);
}

TEST(RestOfPlanTest, TheRestNeedsItsFramesAndTheMarginNamingBothNumbers) {
  const RestOfPlan rest{.frames = 115, .bytes_per_frame = 20'000'000};
  EXPECT_EQ(rest.NeededBytes(), 2'300'000'000);
  EXPECT_OK(CheckRestFits(rest, 2'300'000'000, "/data"));  // exactly enough
  EXPECT_THAT(CheckRestFits(rest, 2'299'999'999, "/data"),
              StatusIs(absl::StatusCode::kResourceExhausted));
  EXPECT_THAT(
      CheckRestFits(rest, 1'200'000'000, "/data"),
      StatusIs(absl::StatusCode::kResourceExhausted,
               HasSubstr("disk has 1.2 GB free on the data root /data, the "
                         "rest of the plan needs 2.3 GB (115 frames of 20.0 "
                         "MB and a 0 B margin); the capture resumes by itself "
                         "once space is freed")));

  const RestOfPlan with_margin{
      .frames = 3, .bytes_per_frame = 1'000'000, .margin = 256 << 20};
  EXPECT_EQ(with_margin.NeededBytes(), 271'435'456);
  EXPECT_THAT(CheckRestFits(with_margin, 200'000'000, "/d"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       HasSubstr("disk has 200.0 MB free on the data root "
                                 "/d, the rest of the plan needs 271.4 MB (3 "
                                 "frames of 1.0 MB and a 268.4 MB margin)")));
  // The last frame written: the margin alone.
  EXPECT_OK(CheckRestFits(
      {.frames = 0, .bytes_per_frame = 20'000'000, .margin = 1000}, 1000,
      "/d"));
}

class DiskGuardEstimateTest : public testing::StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    ASSERT_OK(Session("lab").status());
  }

  // A capture of `kind` (of a job of its own) whose frame files have
  // `sizes` bytes.
  int64_t CaptureWithFrames(io::CaptureKind kind,
                            const std::vector<int>& sizes) {
    store::FrameRepository frames(*store_);
    absl::StatusOr<store::JobRecord> job = Job("lab");
    EXPECT_OK(job.status());
    absl::StatusOr<store::CaptureRecord> capture =
        frames.CaptureForJob(job->id, kind, absl::StrCat("plan ", job->id));
    EXPECT_OK(capture.status());
    store::Transaction tx(store_->db());
    EXPECT_OK(tx.status());
    for (size_t i = 0; i < sizes.size(); ++i) {
      store::FrameRecord f;
      f.capture_id = capture->id;
      f.sequence = static_cast<int>(i);
      f.exposure_s = 0.01;
      f.format = hardware::ImageFormat::kPng8;
      f.path = absl::StrCat("captures/", capture->id, "/f", i, ".png");
      f.sha256 = absl::StrCat("sha", i);
      EXPECT_OK(store_->files().WriteSessionFile("lab", f.path,
                                                 std::string(sizes[i], 'x')));
      EXPECT_OK(frames.InsertLocked(f));
    }
    EXPECT_OK(tx.Commit());
    return capture->id;
  }
};

TEST_F(DiskGuardEstimateTest, TheLastCaptureOfTheSameKindElseTheGuess) {
  const DiskGuard guard(*store_, {.margin_bytes = 1000,
                                  .processing_headroom = 1.0,
                                  .frame_bytes_guess = 5000});
  ASSERT_OK_AND_ASSIGN(int64_t stereo,
                       guard.BytesPerFrame(io::CaptureKind::kBracketedStereo));
  EXPECT_EQ(stereo, 5000);
  const int64_t first =
      CaptureWithFrames(io::CaptureKind::kBracketedStereo, {100, 300, 200});
  ASSERT_OK_AND_ASSIGN(int64_t largest, guard.LargestFrame(first));
  EXPECT_EQ(largest, 300);
  ASSERT_OK_AND_ASSIGN(stereo,
                       guard.BytesPerFrame(io::CaptureKind::kBracketedStereo));
  EXPECT_EQ(stereo, 300);
  ASSERT_OK_AND_ASSIGN(int64_t sl,
                       guard.BytesPerFrame(io::CaptureKind::kStructuredLight));
  EXPECT_EQ(sl, 5000);  // another kind: still the guess
  // The most recent capture of the kind, not the largest of all; one
  // without frames yet does not count.
  CaptureWithFrames(io::CaptureKind::kBracketedStereo, {150});
  const int64_t empty =
      CaptureWithFrames(io::CaptureKind::kBracketedStereo, {});
  ASSERT_OK_AND_ASSIGN(stereo,
                       guard.BytesPerFrame(io::CaptureKind::kBracketedStereo));
  EXPECT_EQ(stereo, 150);
  ASSERT_OK_AND_ASSIGN(largest, guard.LargestFrame(empty));
  EXPECT_EQ(largest, 0);
  // Admission: frames x bytes per frame x (1 + headroom) + margin.
  ASSERT_OK_AND_ASSIGN(
      int64_t needed, guard.NeededBytes(io::CaptureKind::kBracketedStereo, 10));
  EXPECT_EQ(needed, 10 * 150 * 2 + 1000);
}

// Admission subtracts what unfinished captures were promised; the running
// capture's frame boundary does not (its own promise is among them, and it
// would be suspended for space promised to itself).
TEST_F(DiskGuardEstimateTest, AFrameBoundaryDoesNotCountThePromises) {
  const DiskGuard guard(*store_, {.margin_bytes = 0,
                                  .processing_headroom = 1.0,
                                  .frame_bytes_guess = int64_t{1} << 40});
  v1::CapturePlan plan;
  plan.mutable_structured_light();
  ASSERT_OK(store::JobRepository(*store_)
                .Create(store::JobKind::kCapture, "lab",
                        plan.SerializeAsString(), 1000, "queued", "tester")
                .status());
  ASSERT_OK_AND_ASSIGN(int64_t promised, guard.PendingCaptureBytes());
  EXPECT_EQ(promised, int64_t{1000} * (int64_t{1} << 40) * 2);
  EXPECT_THAT(guard.CheckRoomFor(io::CaptureKind::kStructuredLight, 1),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       HasSubstr("of it promised to queued captures")));
  EXPECT_OK(guard.CheckRoomForRest(1, 1));
}

// A queued capture that chooses its exposures at the rig has no frame
// count yet (0): it is promised the default bracket's 17 frames until it
// has metered the scene, as it was admitted.
TEST_F(DiskGuardEstimateTest,
       AnUnmeteredAutoBracketIsPromisedTheDefaultBracket) {
  const DiskGuard guard(*store_, {.margin_bytes = 0,
                                  .processing_headroom = 1.0,
                                  .frame_bytes_guess = 100});
  v1::CapturePlan request;
  request.mutable_bracketed_stereo()->mutable_auto_bracket();
  ASSERT_OK_AND_ASSIGN(const v1::CapturePlan plan, NormalizePlan(request, {}));
  ASSERT_TRUE(ChoosesExposuresAtTheRig(plan));
  EXPECT_EQ(ExpandPlan(WithDefaultExposures(plan), {}, 0).size(), 17u);
  ASSERT_OK_AND_ASSIGN(const store::JobRecord job,
                       store::JobRepository(*store_).Create(
                           store::JobKind::kCapture, "lab",
                           plan.SerializeAsString(), 0, "queued", "tester"));
  ASSERT_OK_AND_ASSIGN(int64_t promised, guard.PendingCaptureBytes());
  EXPECT_EQ(promised, 17 * 100 * 2);
  // Once it has chosen (4 exposures: 9 frames), those are what count.
  {
    store::Transaction tx(store_->db());
    ASSERT_OK(tx.status());
    ASSERT_OK(store::JobRepository(*store_)
                  .SetProgressLocked(job.id, 0, 9, "chosen")
                  .status());
    ASSERT_OK(tx.Commit());
  }
  ASSERT_OK_AND_ASSIGN(promised, guard.PendingCaptureBytes());
  EXPECT_EQ(promised, 9 * 100 * 2);
}

}  // namespace
}  // namespace hdrstereo::jobs
