// SPDX-License-Identifier: GPL-3.0-or-later
//
// The outcome every path into the daemon must give a call of each method by
// a caller of each role, read from the one role table (method_roles.cc):
// what the gRPC test (tests/integration/remote_test.cc), the in-process
// guard test and the HTTP edge's test all check, so that every transport
// answers alike. Link hdrstereo_daemon.
#ifndef HDRSTEREO_TESTS_SUPPORT_ROLE_OUTCOMES_H_
#define HDRSTEREO_TESTS_SUPPORT_ROLE_OUTCOMES_H_

#include <gmock/gmock.h>
#include <grpcpp/support/status.h>
#include <gtest/gtest.h>

#include <string>

#include "absl/strings/str_cat.h"
#include "daemon/rpc/method_roles.h"
#include "daemon/rpc/roles.h"

namespace hdrstereo::testing {

// Checks `status`, the answer to a call of `method` (full name, e.g.
// "/hdrstereo.v1.Jobs/Cancel") with an empty request by the authenticated
// principal `user` having `role` (kNone: a principal without a role):
// PERMISSION_DENIED naming the role needed and the one `user` has when the
// role table says so, else neither PERMISSION_DENIED nor UNAUTHENTICATED
// (what the handler makes of the empty request is its own matter).
inline void ExpectRoleOutcome(const std::string& method,
                              const std::string& user, rpc::Role role,
                              const grpc::Status& status) {
  const rpc::MethodRule* rule = rpc::FindMethodRule(method);
  ASSERT_NE(rule, nullptr) << method << " is not in the role table";
  if (rule->min_role > role) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::PERMISSION_DENIED)
        << method << " as " << user << ": " << status.error_message();
    EXPECT_THAT(
        status.error_message(),
        ::testing::HasSubstr(absl::StrCat(
            method, " needs role ", rpc::RoleName(rule->min_role), "; ", user,
            " has ",
            role == rpc::Role::kNone ? "no role" : rpc::RoleName(role))))
        << method << " as " << user;
  } else {
    EXPECT_NE(status.error_code(), grpc::StatusCode::PERMISSION_DENIED)
        << method << " as " << user << ": " << status.error_message();
    EXPECT_NE(status.error_code(), grpc::StatusCode::UNAUTHENTICATED)
        << method << " as " << user << ": " << status.error_message();
  }
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_ROLE_OUTCOMES_H_
