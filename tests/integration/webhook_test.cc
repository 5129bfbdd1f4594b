// SPDX-License-Identifier: GPL-3.0-or-later
//
// Webhooks end to end: an admin configures one with the CLI, the real
// daemon captures on simulated hardware, and a receiver on 127.0.0.1 gets
// each job's final state signed with the secret the CLI printed. A receiver
// that hangs does not hold up the next capture.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/http_receiver.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

using ::testing::HasSubstr;
using ::testing::MatchesRegex;

class WebhookTest : public testing::DaemonFixture {};

TEST_F(WebhookTest, CaptureOutcomesReachTheReceiverSignedWithoutSlowingIt) {
  testing::HttpReceiver receiver;
  StartDaemon({"--sim-scene",
               WriteScene("lab-lamp", testing::SmallLabLamp()).string(),
               "--webhook-timeout-s", "120"});

  testing::CommandResult ftp =
      Cli({"admin", "webhook", "create", "--url", "ftp://files.example.org/"});
  EXPECT_EQ(ftp.exit_code, 2) << ftp.err;  // INVALID_ARGUMENT
  EXPECT_THAT(ftp.err, HasSubstr("url scheme \"ftp\" is not supported"));
  testing::CommandResult unknown =
      Cli({"admin", "webhook", "create", "--url", receiver.Url(), "--events",
           "job.finished"});
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_THAT(unknown.err, HasSubstr("\"job.finished\" is not an event type"));

  testing::CommandResult created =
      Cli({"admin", "webhook", "create", "--url", receiver.Url(), "--events",
           "job.succeeded,job.failed", "--note", "lab chat"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  const std::string secret(absl::StripAsciiWhitespace(created.out));
  ASSERT_THAT(secret, MatchesRegex("whsec_[0-9a-f]{64}"));
  EXPECT_THAT(created.err, HasSubstr("shown only now"));
  // The secret is in neither the database (nor its journal) nor the log.
  const std::string hex = secret.substr(6);
  for (const char* file : {"hdrstereo.db", "hdrstereo.db-wal"}) {
    const std::filesystem::path path = data_root() / file;
    if (!std::filesystem::exists(path)) continue;
    EXPECT_THAT(testing::ReadFileOrDie(path), ::testing::Not(HasSubstr(hex)))
        << file;
  }
  EXPECT_THAT(daemon_log(), ::testing::Not(HasSubstr(hex)));

  // The first capture's notification hangs in a receiver that never
  // answers; the second capture runs to its end meanwhile.
  receiver.Hang();
  ASSERT_EQ(Cli({"session", "create", "night-1"}).exit_code, 0);
  testing::CommandResult first =
      Cli({"capture", "stereo", "night-1", "--watch"});
  ASSERT_EQ(first.exit_code, 0) << first.out << first.err;
  ASSERT_TRUE(receiver.WaitFor(1, absl::Seconds(60), /*count_held=*/true))
      << daemon_log();
  ASSERT_EQ(Cli({"session", "create", "night-2"}).exit_code, 0);
  testing::CommandResult second =
      Cli({"capture", "stereo", "night-2", "--watch"});
  ASSERT_EQ(second.exit_code, 0) << second.out << second.err;
  EXPECT_EQ(receiver.held(), 1);  // still stuck on the first notification
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs WHERE state = 'succeeded'"), "2");

  receiver.Release();
  ASSERT_TRUE(receiver.WaitFor(2, absl::Seconds(60))) << daemon_log();
  std::set<std::string> sessions;
  std::set<std::string> event_ids;
  for (const testing::ReceivedRequest& r : receiver.requests()) {
    EXPECT_EQ(r.headers.at("x-hdrstereo-event"), "job.succeeded");
    EXPECT_EQ(r.headers.at("x-hdrstereo-signature"),
              testing::ExpectedSignature(secret, r.body));
    const nlohmann::json body = nlohmann::json::parse(r.body);
    EXPECT_EQ(body["job"]["state"], "succeeded");
    EXPECT_EQ(body["job"]["kind"], "capture");
    EXPECT_EQ(body["job"]["submitted_by"], "local");
    EXPECT_EQ(body["id"], r.headers.at("x-hdrstereo-event-id"));
    sessions.insert(body["job"]["session"].get<std::string>());
    event_ids.insert(r.headers.at("x-hdrstereo-event-id"));
  }
  EXPECT_EQ(sessions, (std::set<std::string>{"night-1", "night-2"}));
  EXPECT_EQ(event_ids.size(), 2u);

  const nlohmann::json hooks = CliJson({"admin", "webhook", "list"});
  ASSERT_EQ(hooks["webhooks"].size(), 1u) << hooks.dump(2);
  const nlohmann::json& hook = hooks["webhooks"][0];
  EXPECT_EQ(hook["url"], receiver.Url());
  EXPECT_EQ(hook["note"], "lab chat");
  EXPECT_EQ(hook["created_by"], "local");
  EXPECT_EQ(testing::JsonInt(hook["delivered"]), 2) << hook.dump(2);
  const std::string id = std::to_string(testing::JsonInt(hook["id"]));
  const nlohmann::json deliveries =
      CliJson({"admin", "webhook", "deliveries", id});
  ASSERT_EQ(deliveries["deliveries"].size(), 2u) << deliveries.dump(2);
  for (const nlohmann::json& d : deliveries["deliveries"]) {
    EXPECT_EQ(d["http_status"], 200);
    EXPECT_EQ(d["event_state"], "delivered");
  }
  testing::CommandResult audit = Cli({"audit", "--method", "Webhook"});
  EXPECT_THAT(audit.out, HasSubstr(absl::StrCat("webhook ", id)));

  ASSERT_EQ(Cli({"admin", "webhook", "delete", id}).exit_code, 0);
  testing::CommandResult again = Cli({"admin", "webhook", "delete", id});
  EXPECT_EQ(again.exit_code, 4);  // NOT_FOUND
  EXPECT_THAT(again.err, HasSubstr(absl::StrCat("no webhook ", id)));
}

}  // namespace
}  // namespace hdrstereo
