// SPDX-License-Identifier: GPL-3.0-or-later
//
// Which job events and schedule runs are webhook events, their bodies, the
// URL and filter rules an admin's request must meet, the retry schedule,
// and the signature (against RFC 4231's HMAC-SHA256 vectors) and secret
// derivation.
#include "daemon/notify/webhook_events.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>

#include "daemon/notify/webhook_signing.h"
#include "nlohmann/json.hpp"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::notify {
namespace {

using ::hdrstereo::testing::StatusIs;
using store::JobState;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Optional;

store::JobEventRow Event(JobState state, const std::string& message,
                         std::optional<JobState> previous) {
  store::JobEventRow row;
  row.row_id = 40;
  row.event.job_id = 7;
  row.event.sequence = 3;
  row.event.time_ms = 1764694800123;  // 2025-12-02T17:00:00.123Z
  row.event.state = state;
  row.event.message = message;
  row.event.progress_done = 5;
  row.event.progress_total = 17;
  row.previous_state = previous;
  row.job.id = 7;
  row.job.kind = store::JobKind::kCapture;
  row.job.session = "lab-1";
  row.job.state = state;
  row.job.error = "camera did not answer";
  row.job.submitted_by = "alice";
  return row;
}

TEST(JobEventTypeTest, FinalStatesOnceSuspensionsAndResumptions) {
  EXPECT_THAT(
      JobEventType(Event(JobState::kSucceeded, "done", JobState::kRunning)),
      Optional(std::string("job.succeeded")));
  EXPECT_THAT(
      JobEventType(Event(JobState::kFailed, "failed", JobState::kRunning)),
      Optional(std::string("job.failed")));
  EXPECT_THAT(JobEventType(Event(JobState::kCancelled,
                                 "cancelled before it "
                                 "started",
                                 JobState::kQueued)),
              Optional(std::string("job.cancelled")));
  // A note recorded after the final state is not a second final event.
  EXPECT_EQ(
      JobEventType(Event(JobState::kFailed, "log attached", JobState::kFailed)),
      std::nullopt);
  EXPECT_THAT(
      JobEventType(Event(JobState::kPaused, "suspended: disk has 1.2 GB",
                         JobState::kRunning)),
      Optional(std::string("job.suspended")));
  EXPECT_THAT(JobEventType(Event(JobState::kRunning,
                                 "resumed: the condition cleared (was: x)",
                                 JobState::kPaused)),
              Optional(std::string("job.resumed")));
  // A person's pause and resume, progress and start are not events.
  EXPECT_EQ(
      JobEventType(Event(JobState::kPaused, "paused", JobState::kRunning)),
      std::nullopt);
  EXPECT_EQ(
      JobEventType(Event(JobState::kRunning, "resumed", JobState::kPaused)),
      std::nullopt);
  EXPECT_EQ(
      JobEventType(Event(JobState::kRunning, "started", JobState::kQueued)),
      std::nullopt);
  EXPECT_EQ(JobEventType(Event(JobState::kQueued, "queued", std::nullopt)),
            std::nullopt);
}

TEST(JobEventBodyTest, CarriesWhatAPersonNeeds) {
  const store::JobEventRow row =
      Event(JobState::kFailed, "frame 6: exposure off", JobState::kRunning);
  const nlohmann::json body =
      nlohmann::json::parse(JobEventBody(row, "job.failed", "rig-3"));
  EXPECT_EQ(body["id"], "job-7-event-3");
  EXPECT_EQ(JobEventId(row), "job-7-event-3");
  EXPECT_EQ(body["type"], "job.failed");
  EXPECT_EQ(body["time"], "2025-12-02T17:00:00.123Z");
  EXPECT_EQ(body["daemon"], "rig-3");
  EXPECT_EQ(body["job"]["id"], 7);
  EXPECT_EQ(body["job"]["kind"], "capture");
  EXPECT_EQ(body["job"]["session"], "lab-1");
  EXPECT_EQ(body["job"]["state"], "failed");
  EXPECT_EQ(body["job"]["message"], "frame 6: exposure off");
  EXPECT_EQ(body["job"]["error"], "camera did not answer");
  EXPECT_EQ(body["job"]["progress_done"], 5);
  EXPECT_EQ(body["job"]["progress_total"], 17);
  EXPECT_EQ(body["job"]["submitted_by"], "alice");
  // Only a failed job has an error.
  const nlohmann::json ok = nlohmann::json::parse(
      JobEventBody(Event(JobState::kSucceeded, "done", JobState::kRunning),
                   "job.succeeded", "rig-3"));
  EXPECT_FALSE(ok["job"].contains("error"));
}

TEST(ScheduleRunBodyTest, OutcomeAndReason) {
  store::ScheduleRunRecord run;
  run.id = 12;
  run.schedule = "nightly";
  run.due_time_ms = 1764637200000;  // 2025-12-02T01:00:00Z
  run.end_time_ms = 1764637260000;
  run.outcome = store::RunOutcome::kSkipped;
  run.reason = "the rig is locked by bob";
  run.caused_by = "alice";
  EXPECT_EQ(ScheduleRunEventType(run), "schedule_run.skipped");
  EXPECT_EQ(ScheduleRunEventId(run), "schedule-run-12");
  const nlohmann::json body =
      nlohmann::json::parse(ScheduleRunBody(run, "rig-3"));
  EXPECT_EQ(body["type"], "schedule_run.skipped");
  EXPECT_EQ(body["time"], "2025-12-02T01:01:00.000Z");
  EXPECT_EQ(body["schedule_run"]["schedule"], "nightly");
  EXPECT_EQ(body["schedule_run"]["due_time"], "2025-12-02T01:00:00.000Z");
  EXPECT_EQ(body["schedule_run"]["reason"], "the rig is locked by bob");
  EXPECT_EQ(body["schedule_run"]["caused_by"], "alice");
}

TEST(EventFilterTest, KnownTypesAndFamiliesDeduplicated) {
  ASSERT_OK_AND_ASSIGN(
      std::vector<std::string> filter,
      ValidateEventFilter({"job.failed", "schedule_run.*", "job.failed"}));
  EXPECT_THAT(filter, ElementsAre("job.failed", "schedule_run.*"));
  EXPECT_TRUE(FilterMatches(filter, "job.failed"));
  EXPECT_TRUE(FilterMatches(filter, "schedule_run.skipped"));
  EXPECT_FALSE(FilterMatches(filter, "job.succeeded"));
  EXPECT_TRUE(FilterMatches({}, "job.succeeded"));  // empty: every event
  EXPECT_TRUE(FilterMatches({"job.*"}, "job.suspended"));
  EXPECT_FALSE(FilterMatches({"job.*"}, "schedule_run.failed"));
  EXPECT_THAT(ValidateEventFilter({"job.failed", "job.finished"}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("\"job.finished\" is not an event type")));
  EXPECT_THAT(ValidateEventFilter({"*"}),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("job.succeeded, job.failed")));
}

TEST(WebhookUrlTest, EachRuleNamed) {
  EXPECT_OK(ValidateWebhookUrl("https://hooks.example.org/services/T0/B1"));
  EXPECT_OK(ValidateWebhookUrl("http://127.0.0.1:8080/hook?lab=3"));
  EXPECT_THAT(ValidateWebhookUrl(""),
              StatusIs(absl::StatusCode::kInvalidArgument, "url is empty"));
  EXPECT_THAT(ValidateWebhookUrl("ftp://files.example.org/drop"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("url scheme \"ftp\" is not supported")));
  EXPECT_THAT(ValidateWebhookUrl("file:///etc/passwd"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("url scheme \"file\"")));
  EXPECT_THAT(
      ValidateWebhookUrl("hooks.example.org/x"),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("is not a URL")));
  EXPECT_THAT(ValidateWebhookUrl("https://bob:hunter2@hooks.example.org/x"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("must not carry a user name or password")));
  EXPECT_THAT(
      ValidateWebhookUrl("https://example.org/" + std::string(2100, 'a')),
      StatusIs(absl::StatusCode::kInvalidArgument,
               "url is longer than 2048 bytes"));
}

TEST(WebhookUrlTest, LogsShowOnlyTheOrigin) {
  EXPECT_EQ(UrlOrigin("https://hooks.example.org/services/T0/B1/SECRET"),
            "https://hooks.example.org");
  EXPECT_EQ(UrlOrigin("http://127.0.0.1:8080/hook?token=abc"),
            "http://127.0.0.1:8080");
}

TEST(RetryDelayTest, DoublesCapsAndGivesUp) {
  const RetryPolicy policy{.max_attempts = 5,
                           .first_retry = absl::Seconds(5),
                           .max_retry = absl::Seconds(30)};
  EXPECT_EQ(RetryDelay(policy, 1, 500), absl::Seconds(5));
  EXPECT_EQ(RetryDelay(policy, 2, 0), absl::Seconds(10));  // no response
  EXPECT_EQ(RetryDelay(policy, 3, 503), absl::Seconds(20));
  EXPECT_EQ(RetryDelay(policy, 4, 429), absl::Seconds(30));  // capped
  EXPECT_EQ(RetryDelay(policy, 5, 500), std::nullopt);       // all used
  EXPECT_EQ(RetryDelay(policy, 1, 408), absl::Seconds(5));
  // The receiver says the request itself is wrong: retrying cannot help.
  EXPECT_EQ(RetryDelay(policy, 1, 404), std::nullopt);
  EXPECT_EQ(RetryDelay(policy, 1, 401), std::nullopt);
}

TEST(WebhookSignatureTest, MatchesRfc4231Vectors) {
  // RFC 4231 test case 2.
  EXPECT_THAT(SignatureHeaderValue("Jefe", "what do ya want for nothing?"),
              ::testing::Eq(absl::StatusOr<std::string>(
                  "sha256=5bdcc146bf60754e6a042426089575c75a003f089d2739839dec5"
                  "8b964ec3843")));
  // RFC 4231 test case 1: key 0x0b * 20, data "Hi There".
  EXPECT_THAT(SignatureHeaderValue(std::string(20, '\x0b'), "Hi There"),
              ::testing::Eq(absl::StatusOr<std::string>(
                  "sha256=b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e93"
                  "76c2e32cff7")));
}

TEST(WebhookSignerTest, KeyFileIsPrivateAndSecretsDifferPerSalt) {
  testing::TempDir dir;
  ASSERT_OK_AND_ASSIGN(WebhookSigner signer, WebhookSigner::Open(dir.path()));
  const std::filesystem::path key = dir.path() / "keys/webhook-signing.key";
  struct stat info {};
  ASSERT_EQ(::stat(key.c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 0777, 0600);
  ASSERT_EQ(::stat(key.parent_path().c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 0777, 0700);

  ASSERT_OK_AND_ASSIGN(std::string salt_a, WebhookSigner::NewSalt());
  ASSERT_OK_AND_ASSIGN(std::string salt_b, WebhookSigner::NewSalt());
  EXPECT_NE(salt_a, salt_b);
  ASSERT_OK_AND_ASSIGN(std::string secret_a, signer.SecretFor(salt_a));
  ASSERT_OK_AND_ASSIGN(std::string secret_b, signer.SecretFor(salt_b));
  EXPECT_THAT(secret_a, ::testing::MatchesRegex("whsec_[0-9a-f]{64}"));
  EXPECT_NE(secret_a, secret_b);
  // A restart reads the same key: the same salt gives the same secret.
  ASSERT_OK_AND_ASSIGN(WebhookSigner again, WebhookSigner::Open(dir.path()));
  EXPECT_THAT(again.SecretFor(salt_a),
              ::testing::Eq(absl::StatusOr<std::string>(secret_a)));
  // Another data root's key gives another secret for the same salt.
  testing::TempDir other_dir;
  ASSERT_OK_AND_ASSIGN(WebhookSigner other,
                       WebhookSigner::Open(other_dir.path()));
  ASSERT_OK_AND_ASSIGN(std::string other_secret, other.SecretFor(salt_a));
  EXPECT_NE(other_secret, secret_a);
  EXPECT_THAT(signer.SecretFor("zz"),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("salt")));
}

TEST(WebhookSignerTest, RefusesAKeyOthersCanReadOrABrokenOne) {
  testing::TempDir dir;
  ASSERT_OK(WebhookSigner::Open(dir.path()).status());
  const std::filesystem::path key = dir.path() / "keys/webhook-signing.key";
  std::filesystem::permissions(key, std::filesystem::perms::group_read,
                               std::filesystem::perm_options::add);
  EXPECT_THAT(WebhookSigner::Open(dir.path()),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("is readable by others; chmod 600")));
  std::filesystem::permissions(key, std::filesystem::perms::owner_read |
                                        std::filesystem::perms::owner_write);
  std::ofstream(key) << "not hex\n";
  EXPECT_THAT(WebhookSigner::Open(dir.path()),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("is not a signing key")));
}

}  // namespace
}  // namespace hdrstereo::notify
