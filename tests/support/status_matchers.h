// SPDX-License-Identifier: GPL-3.0-or-later
//
// GoogleTest matchers for absl::Status and absl::StatusOr<T> (Debian 12's
// abseil predates absl/status/status_matchers.h):
//
//   EXPECT_OK(store.Put(row));
//   EXPECT_THAT(ReadImage(path), StatusIs(absl::StatusCode::kNotFound,
//                                         HasSubstr("no such file")));
//   ASSERT_OK_AND_ASSIGN(cv::Mat image, ReadImage(path));
//
// A test of a failure checks the code and what the message says, so that it
// cannot pass when the call fails for another reason.
#ifndef HDRSTEREO_TESTS_SUPPORT_STATUS_MATCHERS_H_
#define HDRSTEREO_TESTS_SUPPORT_STATUS_MATCHERS_H_

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::testing {
namespace status_internal {

inline const absl::Status& GetStatus(const absl::Status& status) {
  return status;
}
template <typename T>
const absl::Status& GetStatus(const absl::StatusOr<T>& status_or) {
  return status_or.status();
}

}  // namespace status_internal

// Matches an OK absl::Status or absl::StatusOr<T>.
MATCHER(IsOk, negation ? "is not OK" : "is OK") {
  const absl::Status& status = status_internal::GetStatus(arg);
  if (!status.ok()) *result_listener << "which is " << status;
  return status.ok();
}

// Matches a status (or StatusOr) with `code`.
MATCHER_P(StatusIs, code,
          std::string(negation ? "has a code other than " : "has code ") +
              absl::StatusCodeToString(code)) {
  const absl::Status& status = status_internal::GetStatus(arg);
  *result_listener << "which is " << status;
  return status.code() == code;
}

// Matches a status (or StatusOr) with `code` and a message that matches
// `message_matcher` (e.g. HasSubstr("exposure")).
MATCHER_P2(StatusIs, code, message_matcher,
           std::string(negation ? "is not " : "is ") +
               absl::StatusCodeToString(code) + " with a message that " +
               ::testing::DescribeMatcher<std::string>(message_matcher,
                                                       negation)) {
  const absl::Status& status = status_internal::GetStatus(arg);
  *result_listener << "which is " << status;
  return status.code() == code &&
         ::testing::Matches(message_matcher)(std::string(status.message()));
}

}  // namespace hdrstereo::testing

#define EXPECT_OK(expr) EXPECT_THAT((expr), ::hdrstereo::testing::IsOk())
#define ASSERT_OK(expr) ASSERT_THAT((expr), ::hdrstereo::testing::IsOk())

// Asserts that `expr` (an absl::StatusOr<T>) is OK and moves its value into
// `lhs` (a declaration or an existing variable).
#define ASSERT_OK_AND_ASSIGN(lhs, expr)                                     \
  HDRSTEREO_ASSERT_OK_AND_ASSIGN_IMPL_(                                     \
      HDRSTEREO_STATUS_CONCAT_(hdrstereo_test_statusor_, __LINE__), lhs, \
      expr)

#define HDRSTEREO_ASSERT_OK_AND_ASSIGN_IMPL_(statusor, lhs, expr) \
  auto statusor = (expr);                                         \
  ASSERT_TRUE(statusor.ok()) << statusor.status();                \
  lhs = *std::move(statusor)

#endif  // HDRSTEREO_TESTS_SUPPORT_STATUS_MATCHERS_H_
