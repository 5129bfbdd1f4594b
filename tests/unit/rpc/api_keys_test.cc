// SPDX-License-Identifier: GPL-3.0-or-later
//
// API keys against a real SQLite file: the token's shape and randomness,
// verification (right, wrong, unknown, malformed, expired, revoked), that
// the secret is stored nowhere, and that the in-memory table and the
// database agree across a reload.
#include "daemon/rpc/api_keys.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "absl/strings/ascii.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::rpc {
namespace {

using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;
using ::testing::Not;

class ApiKeysTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_OK_AND_ASSIGN(store_, store::Store::Open(dir_ / "data"));
    ASSERT_OK_AND_ASSIGN(keys_, Load());
  }

  absl::StatusOr<std::unique_ptr<ApiKeyStore>> Load() {
    return ApiKeyStore::Load(*store_, [this] { return now_; });
  }

  // The bytes of the database and its write-ahead log, as on disk.
  std::string DatabaseBytes() {
    std::string bytes = ReadFileOrDie(dir_ / "data" / "hdrstereo.db");
    std::error_code ec;
    if (std::filesystem::exists(dir_ / "data" / "hdrstereo.db-wal", ec)) {
      bytes += ReadFileOrDie(dir_ / "data" / "hdrstereo.db-wal");
    }
    return bytes;
  }

  testing::TempDir dir_;
  std::unique_ptr<store::Store> store_;
  std::unique_ptr<ApiKeyStore> keys_;
  absl::Time now_ = absl::FromUnixSeconds(1'800'000'000);
};

TEST_F(ApiKeysTest, ACreatedKeyVerifiesAsItsUserAndRole) {
  ASSERT_OK_AND_ASSIGN(NewApiKey key,
                       keys_->Create("bob", Role::kOperator, absl::Hours(24),
                                     "notebook", "carol"));
  // hs_<12 hex digits>_<64 hex digits>.
  ASSERT_EQ(key.token.size(), 3u + 12 + 1 + 64) << key.token;
  EXPECT_EQ(key.token.substr(0, 3), "hs_");
  EXPECT_EQ(key.token[15], '_');
  EXPECT_EQ(key.token.find_first_not_of("0123456789abcdef", 3), 15u);
  EXPECT_EQ(key.token.find_first_not_of("0123456789abcdef", 16),
            std::string::npos);
  EXPECT_EQ(ApiKeyIdOf(key.token), key.record.id);
  EXPECT_EQ(key.record.created_by, "carol");
  EXPECT_EQ(key.record.note, "notebook");

  ASSERT_OK_AND_ASSIGN(VerifiedApiKey verified, keys_->Verify(key.token));
  EXPECT_EQ(verified.id, key.record.id);
  EXPECT_EQ(verified.user, "bob");
  EXPECT_EQ(verified.role, Role::kOperator);
  EXPECT_EQ(verified.expire_time, now_ + absl::Hours(24));
}

TEST_F(ApiKeysTest, TheSecretIsStoredNowhere) {
  ASSERT_OK_AND_ASSIGN(
      NewApiKey key,
      keys_->Create("bob", Role::kViewer, absl::Hours(1), "", "carol"));
  const std::string secret = key.token.substr(key.token.rfind('_') + 1);
  ASSERT_EQ(secret.size(), 64u);
  const std::string bytes = DatabaseBytes();
  EXPECT_THAT(bytes, HasSubstr(key.record.id));  // the row is there
  EXPECT_THAT(bytes, Not(HasSubstr(secret)));
  EXPECT_THAT(bytes, Not(HasSubstr(secret.substr(0, 16))));
  EXPECT_NE(key.record.digest_hex, secret);
  EXPECT_EQ(key.record.digest_hex.size(), 64u);  // SHA-256
  EXPECT_EQ(key.record.salt_hex.size(), 32u);
}

TEST_F(ApiKeysTest, KeysAreDistinct) {
  std::set<std::string> ids, secrets, salts;
  for (int i = 0; i < 50; ++i) {
    ASSERT_OK_AND_ASSIGN(
        NewApiKey key,
        keys_->Create("bob", Role::kViewer, absl::Hours(1), "", "carol"));
    ids.insert(key.record.id);
    secrets.insert(key.token.substr(16));
    salts.insert(key.record.salt_hex);
  }
  EXPECT_EQ(ids.size(), 50u);
  EXPECT_EQ(secrets.size(), 50u);
  EXPECT_EQ(salts.size(), 50u);
}

TEST_F(ApiKeysTest, WrongUnknownAndMalformedKeysAreUnauthenticated) {
  ASSERT_OK_AND_ASSIGN(
      NewApiKey key,
      keys_->Create("bob", Role::kOperator, absl::Hours(1), "", "carol"));
  std::string wrong = key.token;
  wrong.back() = wrong.back() == '0' ? '1' : '0';
  EXPECT_THAT(keys_->Verify(wrong),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("unknown or its secret is wrong")));
  std::string unknown = key.token;
  unknown[3] = unknown[3] == 'a' ? 'b' : 'a';
  EXPECT_THAT(keys_->Verify(unknown),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("unknown or its secret is wrong")));
  for (const std::string& bad :
       {std::string(""), std::string("hs_"), key.token.substr(1),
        key.token + "0", std::string("Bearer ") + key.token,
        absl::AsciiStrToUpper(key.token)}) {
    EXPECT_THAT(keys_->Verify(bad),
                StatusIs(absl::StatusCode::kUnauthenticated,
                         HasSubstr("expected \"Bearer hs_<id>_<secret>\"")))
        << bad;
  }
  // No message repeats the secret.
  absl::Status status = keys_->Verify(wrong).status();
  EXPECT_THAT(std::string(status.message()),
              Not(HasSubstr(wrong.substr(16, 16))));
}

TEST_F(ApiKeysTest, AnExpiredKeyFails) {
  ASSERT_OK_AND_ASSIGN(
      NewApiKey key,
      keys_->Create("bob", Role::kOperator, absl::Minutes(5), "", "carol"));
  now_ += absl::Minutes(4);
  EXPECT_THAT(keys_->Verify(key.token), IsOk());
  now_ += absl::Minutes(1);
  EXPECT_THAT(
      keys_->Verify(key.token),
      StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("expired at")));
  EXPECT_TRUE(keys_->List("", false).empty());
  EXPECT_EQ(keys_->List("", true).size(), 1u);
}

TEST_F(ApiKeysTest, ARevokedKeyFailsAtOnceAndAfterARestart) {
  ASSERT_OK_AND_ASSIGN(
      NewApiKey key,
      keys_->Create("bob", Role::kOperator, absl::Hours(1), "", "carol"));
  ASSERT_THAT(keys_->Verify(key.token), IsOk());
  ASSERT_OK_AND_ASSIGN(store::ApiKeyRecord revoked,
                       keys_->Revoke(key.record.id, "carol"));
  EXPECT_EQ(revoked.revoked_by, "carol");
  EXPECT_THAT(
      keys_->Verify(key.token),
      StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("was revoked")));
  EXPECT_THAT(keys_->Revoke(key.record.id, "carol"),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("already revoked")));
  EXPECT_THAT(keys_->Revoke("0123456789ab", "carol"),
              StatusIs(absl::StatusCode::kNotFound));
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<ApiKeyStore> reloaded, Load());
  EXPECT_THAT(
      reloaded->Verify(key.token),
      StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("was revoked")));
}

TEST_F(ApiKeysTest, AKeyOutlivesARestart) {
  ASSERT_OK_AND_ASSIGN(
      NewApiKey key,
      keys_->Create("alice", Role::kViewer, absl::Hours(1), "", "carol"));
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<ApiKeyStore> reloaded, Load());
  ASSERT_OK_AND_ASSIGN(VerifiedApiKey verified, reloaded->Verify(key.token));
  EXPECT_EQ(verified.user, "alice");
}

TEST_F(ApiKeysTest, BadTtlNoteOrRoleIsRefusedAndStoresNothing) {
  for (absl::Duration ttl : {absl::ZeroDuration(), absl::Seconds(-1),
                             kMaxApiKeyTtl + absl::Seconds(1)}) {
    EXPECT_THAT(keys_->Create("bob", Role::kViewer, ttl, "", "carol"),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("1 s to 366 days")));
  }
  EXPECT_THAT(
      keys_->Create("bob", Role::kViewer, absl::Hours(1),
                    std::string(1025, 'n'), "carol"),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("at most 1024")));
  EXPECT_THAT(keys_->Create("bob", Role::kNone, absl::Hours(1), "", "carol"),
              StatusIs(absl::StatusCode::kInvalidArgument));
  EXPECT_TRUE(keys_->List("", true).empty());
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<ApiKeyStore> reloaded, Load());
  EXPECT_TRUE(reloaded->List("", true).empty());
}

TEST_F(ApiKeysTest, LastUseIsRecordedAtMostEveryMinute) {
  ASSERT_OK_AND_ASSIGN(
      NewApiKey key,
      keys_->Create("bob", Role::kViewer, absl::Hours(1), "", "carol"));
  EXPECT_FALSE(keys_->List("bob", false)[0].last_used_time_ms.has_value());
  ASSERT_THAT(keys_->Verify(key.token), IsOk());
  const int64_t first = absl::ToUnixMillis(now_);
  now_ += absl::Seconds(30);
  ASSERT_THAT(keys_->Verify(key.token), IsOk());
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<ApiKeyStore> reloaded, Load());
  EXPECT_EQ(reloaded->List("bob", false)[0].last_used_time_ms, first);
  now_ += absl::Minutes(1);
  ASSERT_THAT(keys_->Verify(key.token), IsOk());
  ASSERT_OK_AND_ASSIGN(reloaded, Load());
  EXPECT_EQ(reloaded->List("bob", false)[0].last_used_time_ms,
            absl::ToUnixMillis(now_));
}

TEST_F(ApiKeysTest, ListFiltersByUser) {
  ASSERT_THAT(keys_->Create("bob", Role::kViewer, absl::Hours(1), "", "carol"),
              IsOk());
  ASSERT_THAT(
      keys_->Create("alice", Role::kViewer, absl::Hours(1), "", "carol"),
      IsOk());
  EXPECT_EQ(keys_->List("bob", false).size(), 1u);
  EXPECT_EQ(keys_->List("", false).size(), 2u);
  EXPECT_TRUE(keys_->List("dave", true).empty());
}

}  // namespace
}  // namespace hdrstereo::rpc
