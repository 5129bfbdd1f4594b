// SPDX-License-Identifier: GPL-3.0-or-later
//
// The rig lock on a real SQLite file with an injected clock: who may take,
// renew and release it, its expiry, its bounds, the reason others read, and
// that a restart keeps it.
#include "daemon/jobs/rig_lock.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::jobs {
namespace {

using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

class RigLockTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_OK_AND_ASSIGN(store_, store::Store::Open(dir_ / "data"));
    ASSERT_OK_AND_ASSIGN(lock_, Load());
  }
  absl::StatusOr<std::unique_ptr<RigLock>> Load() {
    return RigLock::Load(*store_, [this] { return now_; });
  }
  // "HH:MM" of `t` in the daemon's zone, as the reason names it.
  static std::string Clock(absl::Time t) {
    return absl::FormatTime("%H:%M", t, absl::LocalTimeZone());
  }

  testing::TempDir dir_;
  std::unique_ptr<store::Store> store_;
  std::unique_ptr<RigLock> lock_;
  absl::Time now_ = absl::FromUnixSeconds(1'800'000'000);
};

TEST_F(RigLockTest, OthersAreRefusedWithHolderExpiryAndNote) {
  EXPECT_THAT(lock_->CheckFor("erin"), IsOk());
  ASSERT_OK_AND_ASSIGN(
      RigLockState state,
      lock_->Acquire("bob", "re-aligning the projector", absl::Hours(2)));
  EXPECT_EQ(state.holder, "bob");
  EXPECT_EQ(state.expire_time, now_ + absl::Hours(2));
  const std::string reason = "locked by bob until " +
                             Clock(now_ + absl::Hours(2)) +
                             ": re-aligning the projector";
  EXPECT_THAT(lock_->CheckFor("erin"),
              StatusIs(absl::StatusCode::kFailedPrecondition, reason));
  EXPECT_THAT(lock_->CheckFor("bob"), IsOk());
  EXPECT_THAT(lock_->CheckUnattended(),
              StatusIs(absl::StatusCode::kFailedPrecondition, reason));
  EXPECT_THAT(lock_->Acquire("erin", "mine now", absl::Hours(1)),
              StatusIs(absl::StatusCode::kFailedPrecondition, reason));
}

TEST_F(RigLockTest, TheHolderRenewsAndReleasesOthersOnlyByForce) {
  ASSERT_THAT(lock_->Acquire("bob", "first", absl::Hours(1)), IsOk());
  now_ += absl::Minutes(30);
  ASSERT_OK_AND_ASSIGN(RigLockState renewed,
                       lock_->Acquire("bob", "second", absl::Hours(1)));
  EXPECT_EQ(renewed.note, "second");
  EXPECT_EQ(renewed.expire_time, now_ + absl::Hours(1));
  EXPECT_THAT(lock_->Release("erin", false),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("only bob can unlock it")));
  EXPECT_THAT(lock_->Release("carol", true), IsOk());
  EXPECT_FALSE(lock_->Current().has_value());
  EXPECT_THAT(
      lock_->Release("bob", false),
      StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("not locked")));
  ASSERT_THAT(lock_->Acquire("bob", "", absl::Hours(1)), IsOk());
  EXPECT_THAT(lock_->Release("bob", false), IsOk());
  EXPECT_THAT(lock_->CheckFor("erin"), IsOk());
}

TEST_F(RigLockTest, ALockExpiresAtItsTtl) {
  ASSERT_THAT(lock_->Acquire("bob", "", absl::Minutes(10)), IsOk());
  now_ += absl::Minutes(10) - absl::Milliseconds(1);
  EXPECT_FALSE(lock_->CheckFor("erin").ok());
  now_ += absl::Milliseconds(1);
  EXPECT_THAT(lock_->CheckFor("erin"), IsOk());
  EXPECT_FALSE(lock_->Current().has_value());
  EXPECT_THAT(lock_->Acquire("erin", "", absl::Minutes(1)), IsOk());
}

TEST_F(RigLockTest, ARestartKeepsTheLock) {
  ASSERT_THAT(lock_->Acquire("bob", "calibrating", absl::Hours(1)), IsOk());
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<RigLock> reloaded, Load());
  std::optional<RigLockState> state = reloaded->Current();
  ASSERT_TRUE(state.has_value());
  EXPECT_EQ(state->holder, "bob");
  EXPECT_EQ(state->note, "calibrating");
  EXPECT_EQ(state->expire_time, now_ + absl::Hours(1));
  ASSERT_THAT(reloaded->Release("bob", false), IsOk());
  ASSERT_OK_AND_ASSIGN(reloaded, Load());
  EXPECT_FALSE(reloaded->Current().has_value());
}

TEST_F(RigLockTest, BadTtlOrNoteIsRefusedAndChangesNothing) {
  for (absl::Duration ttl : {absl::ZeroDuration(), absl::Seconds(-5),
                             kMaxRigLockTtl + absl::Seconds(1)}) {
    EXPECT_THAT(lock_->Acquire("bob", "", ttl),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("1 s to 7 days")));
  }
  EXPECT_THAT(
      lock_->Acquire("bob", std::string(1025, 'x'), absl::Hours(1)),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("at most 1024")));
  EXPECT_FALSE(lock_->Current().has_value());
  EXPECT_THAT(lock_->Acquire("bob", "", kMaxRigLockTtl), IsOk());
  // A lock that ends on another day names the date.
  EXPECT_THAT(
      lock_->CheckFor("erin"),
      StatusIs(absl::StatusCode::kFailedPrecondition,
               HasSubstr(absl::FormatTime("%Y-%m-%d ", now_ + kMaxRigLockTtl,
                                          absl::LocalTimeZone()))));
}

}  // namespace
}  // namespace hdrstereo::jobs
