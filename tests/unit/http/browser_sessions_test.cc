// SPDX-License-Identifier: GPL-3.0-or-later
//
// Browser sessions on a fake clock: a token starts a session for its key,
// which ends on sign-out, when idle too long, at its absolute lifetime
// (however busy), and when too many others start; tokens are random and
// not what the daemon keeps.
#include "daemon/http/browser_sessions.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "processing/io/sha256.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::http {
namespace {

using ::hdrstereo::testing::StatusIs;

constexpr char kEnded[] =
    "the browser session has ended (signed out, idle too long, expired, or "
    "hdrstereod restarted): sign in again with an API key";

class BrowserSessionsTest : public ::testing::Test {
 protected:
  BrowserSessions Make(BrowserSessionOptions options) {
    return BrowserSessions(options, [this] { return now_; });
  }
  std::string StartOrDie(BrowserSessions& sessions, absl::string_view key) {
    absl::StatusOr<std::string> token = sessions.Start(key);
    EXPECT_OK(token);
    return token.ok() ? *token : std::string();
  }

  absl::Time now_ = absl::FromUnixSeconds(1'800'000'000);
  BrowserSessionOptions options_{absl::Minutes(30), absl::Hours(12), 4};
};

TEST_F(BrowserSessionsTest, AStartedSessionIsUsedAsItsKey) {
  BrowserSessions sessions = Make(options_);
  const std::string token = StartOrDie(sessions, "key-1");
  now_ += absl::Minutes(5);
  ASSERT_OK_AND_ASSIGN(BrowserSession session, sessions.Use(token));
  EXPECT_EQ(session.key_id, "key-1");
  EXPECT_EQ(session.start, now_ - absl::Minutes(5));
  EXPECT_EQ(session.last_use, now_);
  EXPECT_EQ(sessions.size(), 1u);
}

TEST_F(BrowserSessionsTest, ATokenIs64HexDigitsAndNewEachTime) {
  BrowserSessions sessions = Make({absl::Minutes(30), absl::Hours(12), 1000});
  std::set<std::string> tokens;
  for (int i = 0; i < 100; ++i) {
    const std::string token = StartOrDie(sessions, "key");
    ASSERT_EQ(token.size(), 64u) << token;
    for (char c : token) {
      ASSERT_TRUE(absl::ascii_isxdigit(c) && !absl::ascii_isupper(c)) << token;
    }
    tokens.insert(token);
  }
  EXPECT_EQ(tokens.size(), 100u);
  EXPECT_EQ(sessions.size(), 100u);
}

TEST_F(BrowserSessionsTest, AnIdleSessionEndsAndUseKeepsItAlive) {
  BrowserSessions sessions = Make(options_);
  const std::string token = StartOrDie(sessions, "key-1");
  // Used every 29 minutes for 5 hours: never idle for 30.
  for (int i = 0; i < 10; ++i) {
    now_ += absl::Minutes(29);
    ASSERT_OK(sessions.Use(token)) << i;
  }
  now_ += absl::Minutes(30);
  EXPECT_THAT(sessions.Use(token),
              StatusIs(absl::StatusCode::kUnauthenticated, kEnded));
  EXPECT_EQ(sessions.size(), 0u);
  // And stays ended.
  EXPECT_THAT(sessions.Use(token),
              StatusIs(absl::StatusCode::kUnauthenticated, kEnded));
}

TEST_F(BrowserSessionsTest, ASessionEndsAtItsLifetimeHoweverBusy) {
  BrowserSessions sessions = Make(options_);
  const std::string token = StartOrDie(sessions, "key-1");
  const absl::Time start = now_;
  while (now_ + absl::Minutes(10) < start + absl::Hours(12)) {
    now_ += absl::Minutes(10);
    ASSERT_OK(sessions.Use(token)) << now_;
  }
  now_ = start + absl::Hours(12);
  EXPECT_THAT(sessions.Use(token),
              StatusIs(absl::StatusCode::kUnauthenticated, kEnded));
}

TEST_F(BrowserSessionsTest, EndSignsOut) {
  BrowserSessions sessions = Make(options_);
  const std::string token = StartOrDie(sessions, "key-1");
  const std::string other = StartOrDie(sessions, "key-2");
  EXPECT_TRUE(sessions.End(token));
  EXPECT_FALSE(sessions.End(token));
  EXPECT_THAT(sessions.Use(token),
              StatusIs(absl::StatusCode::kUnauthenticated, kEnded));
  ASSERT_OK_AND_ASSIGN(BrowserSession session, sessions.Use(other));
  EXPECT_EQ(session.key_id, "key-2");
}

TEST_F(BrowserSessionsTest, AnUnknownTokenHasNoSession) {
  BrowserSessions sessions = Make(options_);
  const std::string token = StartOrDie(sessions, "key-1");
  std::string altered = token;
  altered[0] = altered[0] == '0' ? '1' : '0';
  for (const std::string& unknown :
       {std::string(), altered, absl::AsciiStrToUpper(token), token + "0",
        token.substr(1), std::string(64, '0'), std::string(100000, 'a')}) {
    EXPECT_THAT(sessions.Use(unknown),
                StatusIs(absl::StatusCode::kUnauthenticated, kEnded));
    EXPECT_FALSE(sessions.End(unknown));
  }
  EXPECT_OK(sessions.Use(token));
}

TEST_F(BrowserSessionsTest, TheTokenItselfIsNotWhatIsKept) {
  // What is kept is the token's SHA-256: knowing it (a memory dump, a log
  // of the map) does not sign anyone in.
  BrowserSessions sessions = Make(options_);
  const std::string token = StartOrDie(sessions, "key-1");
  EXPECT_THAT(sessions.Use(io::Sha256Hex(token)),
              StatusIs(absl::StatusCode::kUnauthenticated, kEnded));
  EXPECT_FALSE(sessions.End(io::Sha256Hex(token)));
  EXPECT_OK(sessions.Use(token));
}

TEST_F(BrowserSessionsTest, BeyondTheLimitTheLeastRecentlyUsedEnds) {
  BrowserSessions sessions = Make(options_);  // 4 at most
  std::string tokens[4];
  for (int i = 0; i < 4; ++i) {
    tokens[i] = StartOrDie(sessions, absl::StrCat("key-", i));
    now_ += absl::Seconds(1);
  }
  // The oldest started is the most recently used.
  ASSERT_OK(sessions.Use(tokens[0]));
  now_ += absl::Seconds(1);
  const std::string fifth = StartOrDie(sessions, "key-4");
  EXPECT_EQ(sessions.size(), 4u);
  EXPECT_THAT(sessions.Use(tokens[1]),
              StatusIs(absl::StatusCode::kUnauthenticated, kEnded));
  for (const std::string& kept : {tokens[0], tokens[2], tokens[3], fifth}) {
    EXPECT_OK(sessions.Use(kept));
  }
}

TEST_F(BrowserSessionsTest, ExpiredSessionsGoBeforeALiveOneIsEvicted) {
  BrowserSessions sessions = Make(options_);  // 4 at most
  const std::string stale = StartOrDie(sessions, "stale");
  now_ += absl::Minutes(20);
  std::string live[3];
  for (std::string& token : live) token = StartOrDie(sessions, "live");
  now_ += absl::Minutes(15);  // `stale` idle 35 minutes, the others 15
  const std::string fifth = StartOrDie(sessions, "fifth");
  EXPECT_EQ(sessions.size(), 4u);
  for (const std::string& kept : {live[0], live[1], live[2], fifth}) {
    EXPECT_OK(sessions.Use(kept));
  }
}

}  // namespace
}  // namespace hdrstereo::http
