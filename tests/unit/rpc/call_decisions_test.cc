// SPDX-License-Identifier: GPL-3.0-or-later
//
// The registry between the guard's interceptor and the handlers' prologue:
// a handler gets the decision recorded for its own call, and fails closed
// when there is none.
#include <gmock/gmock.h>
#include <grpcpp/server_context.h>
#include <gtest/gtest.h>

#include "daemon/rpc/call_guard_interceptor.h"

namespace hdrstereo::rpc {
namespace {

using ::testing::HasSubstr;

Caller Bob() {
  return {.principal = {.name = "bob",
                        .role = Role::kOperator,
                        .auth_method = "cert",
                        .key_expire_time = std::nullopt},
          .transport = kHttpTransport,
          .peer = "ipv4:10.0.0.7:51234"};
}

TEST(CallDecisionsTest, EachCallGetsItsOwnDecision) {
  CallDecisions decisions;
  grpc::ServerContext admitted, refused;
  const int owner = 0;
  decisions.Record(&admitted, &owner, Bob());
  decisions.Record(&refused, &owner,
                   absl::PermissionDeniedError("needs role admin"));
  Caller caller;
  EXPECT_TRUE(decisions.Admit(admitted, &caller).ok());
  EXPECT_EQ(caller.principal.name, "bob");
  EXPECT_EQ(caller.principal.role, Role::kOperator);
  EXPECT_EQ(caller.transport, "http");
  EXPECT_EQ(caller.peer, "ipv4:10.0.0.7:51234");
  EXPECT_TRUE(decisions.Admit(admitted).ok());
  grpc::Status status = decisions.Admit(refused, &caller);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(status.error_message(), "needs role admin");
}

TEST(CallDecisionsTest, NoDecisionIsARefusal) {
  CallDecisions decisions;
  grpc::ServerContext context;
  grpc::Status status = decisions.Admit(context);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INTERNAL);
  EXPECT_THAT(status.error_message(),
              HasSubstr("guard took no decision on this call"));
  // Forgotten when the call ends, but only by the interceptor that
  // recorded it (a later call at the same address keeps its own).
  const int first = 0, second = 0;
  decisions.Record(&context, &first, Bob());
  decisions.Record(&context, &second, Bob());
  decisions.Forget(&context, &first);
  EXPECT_TRUE(decisions.Admit(context).ok());
  decisions.Forget(&context, &second);
  EXPECT_EQ(decisions.Admit(context).error_code(), grpc::StatusCode::INTERNAL);
}

}  // namespace
}  // namespace hdrstereo::rpc
