// SPDX-License-Identifier: GPL-3.0-or-later
//
// Suspenders (fixture: capture_fixture.h): a condition that comes and goes
// while a capture runs suspends it and it resumes by itself.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"
#include "tests/integration/capture_fixture.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::SmallLabLamp;
using ::testing::HasSubstr;

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

}  // namespace
}  // namespace hdrstereo
