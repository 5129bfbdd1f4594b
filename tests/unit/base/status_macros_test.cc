// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/base/status_macros.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "tests/support/status_matchers.h"

namespace hdrstereo {
namespace {

using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;
using ::testing::Not;

absl::Status Check(int value, int* calls) {
  ++*calls;
  if (value < 0) return absl::InvalidArgumentError("value is negative");
  return absl::OkStatus();
}

absl::Status CheckTwice(int first, int second, int* calls) {
  RETURN_IF_ERROR(Check(first, calls));
  RETURN_IF_ERROR(Check(second, calls));
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<int>> Make(int value) {
  if (value == 0) return absl::NotFoundError("no value");
  return std::make_unique<int>(value);
}

// A move-only value, assigned to a declaration and to an existing variable.
absl::StatusOr<int> SumOfMade(int a, int b) {
  ASSIGN_OR_RETURN(std::unique_ptr<int> first, Make(a));
  std::unique_ptr<int> second;
  ASSIGN_OR_RETURN(second, Make(b));
  return *first + *second;
}

TEST(StatusMacrosTest, ReturnIfErrorReturnsTheFirstErrorAndEvaluatesOnce) {
  int calls = 0;
  EXPECT_OK(CheckTwice(1, 2, &calls));
  EXPECT_EQ(calls, 2);
  calls = 0;
  EXPECT_THAT(CheckTwice(-1, 2, &calls),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("negative")));
  EXPECT_EQ(calls, 1);
}

TEST(StatusMacrosTest, AssignOrReturnMovesTheValueOrReturnsTheStatus) {
  ASSERT_OK_AND_ASSIGN(int sum, SumOfMade(2, 3));
  EXPECT_EQ(sum, 5);
  EXPECT_THAT(SumOfMade(2, 0),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("no value")));
  EXPECT_THAT(SumOfMade(0, 2), StatusIs(absl::StatusCode::kNotFound));
}

TEST(StatusMatchersTest, MatchersTellCodesAndMessagesApart) {
  const absl::Status error = absl::FailedPreconditionError("rig is locked");
  EXPECT_THAT(error, Not(IsOk()));
  EXPECT_THAT(absl::OkStatus(), IsOk());
  EXPECT_THAT(error, Not(StatusIs(absl::StatusCode::kInvalidArgument)));
  EXPECT_THAT(error, Not(StatusIs(absl::StatusCode::kFailedPrecondition,
                                  HasSubstr("unlocked"))));
  EXPECT_THAT(absl::StatusOr<int>(error),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("locked")));
  EXPECT_THAT(absl::StatusOr<int>(7), IsOk());
}

}  // namespace
}  // namespace hdrstereo
