// SPDX-License-Identifier: GPL-3.0-or-later
//
// The dispatcher on a real store, POSTing with libcurl to a civetweb
// receiver on 127.0.0.1: what is sent and signed, retries after a 500 with
// the same event id, giving up on a dead receiver, history not replayed,
// filters, schedule runs, a deleted hook's events dropped, and the outbox
// surviving a restart.
#include "daemon/notify/webhook_dispatcher.h"

#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "daemon/store/schedule_repository.h"
#include "nlohmann/json.hpp"
#include "tests/support/http_receiver.h"
#include "tests/support/status_matchers.h"
#include "tests/support/store_fixture.h"

namespace hdrstereo::notify {
namespace {

using store::JobState;
using ::testing::HasSubstr;

constexpr absl::Duration kWait = absl::Seconds(30);

// A loopback port nothing listens on.
int DeadPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), len);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

class WebhookDispatcherTest : public testing::StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    ASSERT_OK_AND_ASSIGN(signer_, WebhookSigner::Open(dir_.path()));
    engine_ = std::make_unique<jobs::JobEngine>(*store_, nullptr, nullptr,
                                                jobs::JobEngineOptions{});
    ASSERT_OK(Session("lab").status());
  }
  void TearDown() override { dispatcher_.reset(); }

  // A hook for `events` (empty: all) and its secret.
  std::string AddHook(const std::string& url,
                      std::vector<std::string> events = {}) {
    absl::StatusOr<std::string> salt = WebhookSigner::NewSalt();
    EXPECT_OK(salt.status());
    store::WebhookRecord record;
    record.url = url;
    record.events = std::move(events);
    record.salt_hex = *salt;
    record.created_by = "admin";
    absl::StatusOr<store::WebhookRecord> hook =
        store::WebhookRepository(*store_).Create(record);
    EXPECT_OK(hook.status());
    hook_id_ = hook->id;
    absl::StatusOr<std::string> secret = signer_->SecretFor(*salt);
    EXPECT_OK(secret.status());
    return *secret;
  }

  void StartDispatcher(int max_attempts = 4) {
    dispatcher_ = std::make_unique<WebhookDispatcher>(
        *store_, *signer_, *engine_,
        WebhookDispatcherOptions{
            .retry = {.max_attempts = max_attempts,
                      .first_retry = absl::Milliseconds(20),
                      .max_retry = absl::Milliseconds(100)},
            .connect_timeout = absl::Seconds(5),
            .request_timeout = absl::Seconds(10),
            .poll = absl::Milliseconds(20),
            .daemon_host = "rig-test"});
    ASSERT_OK(dispatcher_->Start());
  }

  // A capture job that ran and ended in `state`; returns its id.
  int64_t FinishedJob(JobState state) {
    store::JobRepository jobs(*store_);
    absl::StatusOr<store::JobRecord> job = Job("lab");
    EXPECT_OK(job.status());
    EXPECT_OK(jobs.SetState(job->id, JobState::kRunning, "started").status());
    EXPECT_OK(jobs.SetState(job->id, state, "the end",
                            state == JobState::kFailed ? "stage stalled" : "")
                  .status());
    return job->id;
  }

  // Polls the hook's attempts until `count` are recorded; bounded.
  std::vector<store::DeliveryAttempt> WaitForAttempts(size_t count) {
    std::vector<store::DeliveryAttempt> attempts;
    for (const absl::Time end = absl::Now() + kWait; absl::Now() < end;
         absl::SleepFor(absl::Milliseconds(10))) {
      absl::StatusOr<std::vector<store::DeliveryAttempt>> got =
          store::WebhookRepository(*store_).Attempts(hook_id_, 0, 100);
      EXPECT_OK(got.status());
      attempts = *got;
      if (attempts.size() >= count) break;
    }
    return attempts;
  }

  std::optional<WebhookSigner> signer_;
  std::unique_ptr<jobs::JobEngine> engine_;
  std::unique_ptr<WebhookDispatcher> dispatcher_;
  int64_t hook_id_ = 0;
};

TEST_F(WebhookDispatcherTest, SendsASignedEventForAFinalState) {
  testing::HttpReceiver receiver;
  const std::string secret = AddHook(receiver.Url("/hooks/lab"));
  StartDispatcher();
  const int64_t job = FinishedJob(JobState::kFailed);
  ASSERT_TRUE(receiver.WaitFor(1, kWait));
  const testing::ReceivedRequest request = receiver.requests()[0];
  EXPECT_EQ(request.method, "POST");
  EXPECT_EQ(request.path, "/hooks/lab");
  EXPECT_EQ(request.headers.at("content-type"), "application/json");
  EXPECT_EQ(request.headers.at("x-hdrstereo-event"), "job.failed");
  // Queued, started, failed: the third event of the job.
  EXPECT_EQ(request.headers.at("x-hdrstereo-event-id"),
            absl::StrCat("job-", job, "-event-3"));
  EXPECT_EQ(request.headers.at("x-hdrstereo-attempt"), "1");
  EXPECT_EQ(request.headers.at("x-hdrstereo-signature"),
            testing::ExpectedSignature(secret, request.body));
  EXPECT_NE(request.headers.at("x-hdrstereo-signature"),
            testing::ExpectedSignature(secret + "x", request.body));
  const nlohmann::json body = nlohmann::json::parse(request.body);
  EXPECT_EQ(body["type"], "job.failed");
  EXPECT_EQ(body["daemon"], "rig-test");
  EXPECT_EQ(body["job"]["id"], job);
  EXPECT_EQ(body["job"]["error"], "stage stalled");

  const std::vector<store::DeliveryAttempt> attempts = WaitForAttempts(1);
  ASSERT_EQ(attempts.size(), 1u);
  EXPECT_EQ(attempts[0].http_status, 200);
  EXPECT_EQ(attempts[0].error, "");
  EXPECT_EQ(attempts[0].event_state, store::OutboxState::kDelivered);
  // Nothing else was an event: not the queued or started events.
  absl::SleepFor(absl::Milliseconds(200));
  EXPECT_EQ(receiver.requests().size(), 1u);
}

TEST_F(WebhookDispatcherTest, RetriesAfterA500WithTheSameEventId) {
  testing::HttpReceiver receiver;
  receiver.RespondWith({500});
  const std::string secret = AddHook(receiver.Url());
  StartDispatcher();
  FinishedJob(JobState::kSucceeded);
  ASSERT_TRUE(receiver.WaitFor(2, kWait));
  const std::vector<testing::ReceivedRequest> requests = receiver.requests();
  EXPECT_EQ(requests[0].status, 500);
  EXPECT_EQ(requests[1].status, 200);
  EXPECT_EQ(requests[0].headers.at("x-hdrstereo-event-id"),
            requests[1].headers.at("x-hdrstereo-event-id"));
  EXPECT_EQ(requests[0].body, requests[1].body);
  EXPECT_EQ(requests[0].headers.at("x-hdrstereo-attempt"), "1");
  EXPECT_EQ(requests[1].headers.at("x-hdrstereo-attempt"), "2");
  EXPECT_EQ(requests[1].headers.at("x-hdrstereo-signature"),
            testing::ExpectedSignature(secret, requests[1].body));

  // One row per attempt, newest first.
  const std::vector<store::DeliveryAttempt> attempts = WaitForAttempts(2);
  ASSERT_EQ(attempts.size(), 2u);
  EXPECT_EQ(attempts[1].attempt, 1);
  EXPECT_EQ(attempts[1].http_status, 500);
  EXPECT_THAT(attempts[1].error, HasSubstr("HTTP 500: scripted"));
  EXPECT_EQ(attempts[0].attempt, 2);
  EXPECT_EQ(attempts[0].http_status, 200);
  EXPECT_EQ(attempts[0].event_state, store::OutboxState::kDelivered);
}

TEST_F(WebhookDispatcherTest, GivesUpOnADeadReceiverAfterMaxAttempts) {
  AddHook(absl::StrCat("http://127.0.0.1:", DeadPort(), "/hook"));
  StartDispatcher(/*max_attempts=*/3);
  FinishedJob(JobState::kCancelled);
  const std::vector<store::DeliveryAttempt> attempts = WaitForAttempts(3);
  ASSERT_EQ(attempts.size(), 3u);
  for (const store::DeliveryAttempt& attempt : attempts) {
    EXPECT_EQ(attempt.http_status, 0);
    EXPECT_THAT(attempt.error, HasSubstr("connect"));
    EXPECT_EQ(attempt.type, "job.cancelled");
  }
  ASSERT_OK_AND_ASSIGN(std::vector<store::WebhookRecord> hooks,
                       store::WebhookRepository(*store_).List());
  ASSERT_EQ(hooks.size(), 1u);
  EXPECT_EQ(hooks[0].abandoned, 1);
  EXPECT_EQ(hooks[0].pending, 0);
  EXPECT_THAT(hooks[0].last_error, HasSubstr("connect"));
  absl::SleepFor(absl::Milliseconds(300));
  EXPECT_EQ(WaitForAttempts(3).size(), 3u);  // no fourth attempt
}

TEST_F(WebhookDispatcherTest, ARefusalIsNotRetried) {
  testing::HttpReceiver receiver;
  receiver.RespondWith({404});
  AddHook(receiver.Url());
  StartDispatcher();
  FinishedJob(JobState::kSucceeded);
  const std::vector<store::DeliveryAttempt> attempts = WaitForAttempts(1);
  ASSERT_EQ(attempts.size(), 1u);
  EXPECT_EQ(attempts[0].http_status, 404);
  EXPECT_EQ(attempts[0].event_state, store::OutboxState::kAbandoned);
  absl::SleepFor(absl::Milliseconds(300));
  EXPECT_EQ(receiver.requests().size(), 1u);
}

TEST_F(WebhookDispatcherTest, HistoryIsNotReplayedAndFiltersApply) {
  testing::HttpReceiver receiver;
  FinishedJob(JobState::kFailed);  // before notifications started
  AddHook(receiver.Url(), {"job.suspended", "job.resumed"});
  StartDispatcher();
  store::JobRepository jobs(*store_);
  ASSERT_OK_AND_ASSIGN(store::JobRecord job, Job("lab"));
  ASSERT_OK(jobs.SetState(job.id, JobState::kRunning, "started").status());
  ASSERT_OK(jobs.SetState(job.id, JobState::kPaused, "paused").status());
  ASSERT_OK(jobs.SetState(job.id, JobState::kRunning, "resumed").status());
  ASSERT_OK(jobs.SetState(job.id, JobState::kPaused,
                          "suspended: disk has 1.2 GB, the next frame needs "
                          "2.3 GB")
                .status());
  ASSERT_OK(jobs.SetState(job.id, JobState::kRunning,
                          "resumed: the condition cleared (was: disk)")
                .status());
  ASSERT_OK(jobs.SetState(job.id, JobState::kSucceeded, "done").status());
  ASSERT_TRUE(receiver.WaitFor(2, kWait));
  absl::SleepFor(absl::Milliseconds(300));
  const std::vector<testing::ReceivedRequest> requests = receiver.requests();
  ASSERT_EQ(requests.size(), 2u);  // not the old failure, the pause or the end
  EXPECT_EQ(requests[0].headers.at("x-hdrstereo-event"), "job.suspended");
  EXPECT_THAT(nlohmann::json::parse(requests[0].body)["job"]["message"]
                  .get<std::string>(),
              HasSubstr("disk has 1.2 GB"));
  EXPECT_EQ(requests[1].headers.at("x-hdrstereo-event"), "job.resumed");
}

TEST_F(WebhookDispatcherTest, ScheduleRunOutcomesAreAnnouncedOnce) {
  testing::HttpReceiver receiver;
  AddHook(receiver.Url(), {"schedule_run.*"});
  store::ScheduleRepository schedules(*store_);
  store::ScheduleRecord nightly;
  nightly.name = "nightly";
  nightly.cron = "0 2 * * *";
  nightly.plan = "plan";
  nightly.created_by = "admin";
  ASSERT_OK_AND_ASSIGN(store::ScheduleRecord schedule,
                       schedules.Create(nightly, 1000));
  StartDispatcher();
  store::ScheduleRunRecord running;
  running.schedule_id = schedule.id;
  running.due_time_ms = 2000;
  running.outcome = store::RunOutcome::kRunning;
  ASSERT_OK_AND_ASSIGN(store::ScheduleRunRecord run, schedules.AddRun(running));
  absl::SleepFor(absl::Milliseconds(200));
  EXPECT_TRUE(receiver.requests().empty());  // still running: no outcome yet
  run.outcome = store::RunOutcome::kFailed;
  run.end_time_ms = 3000;
  run.reason = "job 4 failed: camera did not answer";
  ASSERT_OK(schedules.UpdateRun(run));
  ASSERT_TRUE(receiver.WaitFor(1, kWait));
  absl::SleepFor(absl::Milliseconds(300));
  const std::vector<testing::ReceivedRequest> requests = receiver.requests();
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].headers.at("x-hdrstereo-event"), "schedule_run.failed");
  EXPECT_EQ(requests[0].headers.at("x-hdrstereo-event-id"),
            absl::StrCat("schedule-run-", run.id));
  EXPECT_EQ(nlohmann::json::parse(requests[0].body)["schedule_run"]["reason"],
            "job 4 failed: camera did not answer");
}

TEST_F(WebhookDispatcherTest, QueuedEventsSurviveARestart) {
  testing::HttpReceiver receiver;
  receiver.Hang();
  const std::string secret = AddHook(receiver.Url());
  StartDispatcher();
  FinishedJob(JobState::kSucceeded);
  ASSERT_TRUE(receiver.WaitFor(1, kWait, /*count_held=*/true));
  // Stopping aborts the request in flight; it is not counted as an attempt.
  dispatcher_.reset();
  EXPECT_TRUE(WaitForAttempts(0).empty());
  FinishedJob(JobState::kFailed);  // while no dispatcher runs
  receiver.Release();
  StartDispatcher();
  ASSERT_TRUE(receiver.WaitFor(3, kWait));  // aborted one + two deliveries
  std::vector<std::string> delivered;
  for (const testing::ReceivedRequest& r : receiver.requests()) {
    EXPECT_EQ(r.headers.at("x-hdrstereo-signature"),
              testing::ExpectedSignature(secret, r.body));
    delivered.push_back(r.headers.at("x-hdrstereo-event"));
  }
  EXPECT_THAT(delivered, ::testing::UnorderedElementsAre(
                             "job.succeeded", "job.succeeded", "job.failed"));
  EXPECT_EQ(WaitForAttempts(2).size(), 2u);
}

TEST_F(WebhookDispatcherTest, ADeletedHookDropsItsQueuedEvents) {
  AddHook(absl::StrCat("http://127.0.0.1:", DeadPort(), "/hook"));
  StartDispatcher(/*max_attempts=*/100);
  FinishedJob(JobState::kFailed);
  ASSERT_FALSE(WaitForAttempts(1).empty());
  store::WebhookRepository hooks(*store_);
  ASSERT_OK_AND_ASSIGN(store::WebhookRecord deleted, hooks.Delete(hook_id_));
  EXPECT_EQ(deleted.pending, 1);
  ASSERT_OK_AND_ASSIGN(std::optional<int64_t> due, hooks.NextDue());
  EXPECT_EQ(due, std::nullopt);
  EXPECT_THAT(
      hooks.Delete(hook_id_),
      testing::StatusIs(absl::StatusCode::kNotFound, HasSubstr("no webhook")));
}

}  // namespace
}  // namespace hdrstereo::notify
