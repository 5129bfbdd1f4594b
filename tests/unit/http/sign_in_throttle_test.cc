// SPDX-License-Identifier: GPL-3.0-or-later
//
// Failed sign-ins per address on a fake clock: refused at the limit, saying
// when to try again, free again once the failures are older than the
// window; addresses are independent and their number bounded.
#include "daemon/http/sign_in_throttle.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/status_matchers.h"

namespace hdrstereo::http {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

class SignInThrottleTest : public ::testing::Test {
 protected:
  SignInThrottle Make(SignInThrottleOptions options) {
    return SignInThrottle(options, [this] { return now_; });
  }

  absl::Time now_ = absl::FromUnixSeconds(1'800'000'000);
  SignInThrottleOptions options_{3, absl::Minutes(1), 100};
};

TEST_F(SignInThrottleTest, UnderTheLimitSignInsAreAllowed) {
  SignInThrottle throttle = Make(options_);
  EXPECT_OK(throttle.Check("10.0.0.1"));
  throttle.RecordFailure("10.0.0.1");
  now_ += absl::Seconds(1);
  throttle.RecordFailure("10.0.0.1");
  EXPECT_OK(throttle.Check("10.0.0.1"));
}

TEST_F(SignInThrottleTest, AtTheLimitTheyAreRefusedSayingWhenToTryAgain) {
  SignInThrottle throttle = Make(options_);
  for (int i = 0; i < 3; ++i) {
    throttle.RecordFailure("10.0.0.1");
    now_ += absl::Seconds(10);
  }
  // The oldest failure is 30 s old: it leaves the window in 30 s.
  EXPECT_THAT(throttle.Check("10.0.0.1"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       "too many failed sign-ins from 10.0.0.1 (3 in the last "
                       "1m); try again in 30 s"));
  // Parts of a second are rounded up.
  now_ += absl::Milliseconds(29'500);
  EXPECT_THAT(throttle.Check("10.0.0.1"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       "too many failed sign-ins from 10.0.0.1 (3 in the last "
                       "1m); try again in 1 s"));
}

TEST_F(SignInThrottleTest, FailuresOlderThanTheWindowNoLongerCount) {
  SignInThrottle throttle = Make(options_);
  const absl::Time first = now_;
  for (int i = 0; i < 3; ++i) {
    throttle.RecordFailure("10.0.0.1");
    now_ += absl::Seconds(10);
  }
  now_ = first + absl::Minutes(1) - absl::Milliseconds(1);
  EXPECT_THAT(throttle.Check("10.0.0.1"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       HasSubstr("try again in 1 s")));
  now_ = first + absl::Minutes(1);
  EXPECT_OK(throttle.Check("10.0.0.1"));
  // One more failure makes three within the window again.
  throttle.RecordFailure("10.0.0.1");
  EXPECT_THAT(throttle.Check("10.0.0.1"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       "too many failed sign-ins from 10.0.0.1 (3 in the last "
                       "1m); try again in 10 s"));
}

TEST_F(SignInThrottleTest, TheWaitCountsFromTheLatestFailuresOnly) {
  SignInThrottle throttle = Make(options_);
  for (int i = 0; i < 10; ++i) {
    throttle.RecordFailure("10.0.0.1");
    now_ += absl::Seconds(1);
  }
  // The three latest failures were 3, 2 and 1 s ago.
  EXPECT_THAT(throttle.Check("10.0.0.1"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       "too many failed sign-ins from 10.0.0.1 (3 in the last "
                       "1m); try again in 57 s"));
}

TEST_F(SignInThrottleTest, AddressesAreCountedApart) {
  SignInThrottle throttle = Make(options_);
  for (int i = 0; i < 3; ++i) throttle.RecordFailure("10.0.0.1");
  for (int i = 0; i < 2; ++i) throttle.RecordFailure("::1");
  EXPECT_THAT(throttle.Check("10.0.0.1"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       HasSubstr("from 10.0.0.1 (3 in the last")));
  EXPECT_OK(throttle.Check("::1"));
  EXPECT_OK(throttle.Check("10.0.0.10"));
  EXPECT_OK(throttle.Check("10.0.0"));
}

TEST_F(SignInThrottleTest, BeyondMaxPeersTheLongestQuietAddressIsForgotten) {
  SignInThrottle throttle = Make({1, absl::Minutes(1), 2});
  throttle.RecordFailure("10.0.0.1");
  now_ += absl::Seconds(1);
  throttle.RecordFailure("10.0.0.2");
  now_ += absl::Seconds(1);
  throttle.RecordFailure("10.0.0.1");  // now the more recent one
  now_ += absl::Seconds(1);
  throttle.RecordFailure("10.0.0.3");  // forgets 10.0.0.2
  EXPECT_OK(throttle.Check("10.0.0.2"));
  EXPECT_THAT(throttle.Check("10.0.0.1"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       "too many failed sign-ins from 10.0.0.1 (1 in the last "
                       "1m); try again in 59 s"));
  EXPECT_THAT(throttle.Check("10.0.0.3"),
              StatusIs(absl::StatusCode::kResourceExhausted,
                       "too many failed sign-ins from 10.0.0.3 (1 in the last "
                       "1m); try again in 60 s"));
}

}  // namespace
}  // namespace hdrstereo::http
