// SPDX-License-Identifier: GPL-3.0-or-later
//
// The HTTP edge's stamp: what Apply writes, Verify reads back, and nothing
// else passes Verify (another boot's stamp, a stamp moved to another caller,
// a missing or repeated key, a caller field beyond its limits).
#include "daemon/rpc/edge_stamp.h"

#include <gmock/gmock.h>
#include <grpcpp/test/client_context_test_peer.h>
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "absl/strings/escaping.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::rpc {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

// Metadata as a server receives it: views into `owned`.
class Metadata {
 public:
  Metadata() = default;
  explicit Metadata(std::multimap<std::string, std::string> owned)
      : owned_(std::move(owned)) {
    for (const auto& [key, value] : owned_) view_.emplace(key, value);
  }
  // What `stamp` adds to a call as `caller`.
  static Metadata Of(const EdgeStamp& stamp, const EdgeCaller& caller) {
    grpc::ClientContext context;
    stamp.Apply(caller, context);
    return Metadata(grpc::testing::ClientContextTestPeer(&context)
                        .GetSendInitialMetadata());
  }
  const std::multimap<grpc::string_ref, grpc::string_ref>& view() const {
    return view_;
  }
  const std::string& Get(const std::string& key) const {
    return owned_.find(key)->second;
  }
  // The same, with `key` set to `value` (nullptr: removed).
  Metadata With(const std::string& key, const char* value) const {
    std::multimap<std::string, std::string> owned = owned_;
    owned.erase(key);
    if (value != nullptr) owned.emplace(key, value);
    return Metadata(owned);
  }

 private:
  std::multimap<std::string, std::string> owned_;
  std::multimap<grpc::string_ref, grpc::string_ref> view_;
};

EdgeCaller Bob() {
  return {.principal = {.name = "bob.smith@lab-1",
                        .role = Role::kOperator,
                        .auth_method = "key:0a1b2c3d4e5f",
                        .key_expire_time = absl::FromUnixMillis(1767225600123)},
          .peer = "ipv6:[2001:db8::7]:51234"};
}

TEST(EdgeStampTest, WhatApplyWritesVerifyReadsBack) {
  ASSERT_OK_AND_ASSIGN(EdgeStamp stamp, EdgeStamp::Create());
  const Metadata metadata = Metadata::Of(stamp, Bob());
  ASSERT_OK_AND_ASSIGN(EdgeCaller caller, stamp.Verify(metadata.view()));
  EXPECT_EQ(caller.principal.name, "bob.smith@lab-1");
  EXPECT_EQ(caller.principal.role, Role::kOperator);
  EXPECT_EQ(caller.principal.auth_method, "key:0a1b2c3d4e5f");
  EXPECT_EQ(caller.principal.key_expire_time,
            absl::FromUnixMillis(1767225600123));
  EXPECT_EQ(caller.peer, "ipv6:[2001:db8::7]:51234");
  EXPECT_TRUE(HasEdgeStamp(metadata.view()));

  // A principal without a role, signed in with a certificate.
  const EdgeCaller dave = {.principal = {.name = "dave",
                                         .role = Role::kNone,
                                         .auth_method = "cert",
                                         .key_expire_time = std::nullopt},
                           .peer = "ipv4:127.0.0.1:80"};
  ASSERT_OK_AND_ASSIGN(caller, stamp.Verify(Metadata::Of(stamp, dave).view()));
  EXPECT_EQ(caller.principal.name, "dave");
  EXPECT_EQ(caller.principal.role, Role::kNone);
  EXPECT_EQ(caller.principal.auth_method, "cert");
  EXPECT_EQ(caller.principal.key_expire_time, std::nullopt);
  EXPECT_EQ(caller.peer, "ipv4:127.0.0.1:80");
}

TEST(EdgeStampTest, EachBootHasItsOwnSecret) {
  ASSERT_OK_AND_ASSIGN(EdgeStamp first, EdgeStamp::Create());
  ASSERT_OK_AND_ASSIGN(EdgeStamp second, EdgeStamp::Create());
  const Metadata by_first = Metadata::Of(first, Bob());
  const Metadata by_second = Metadata::Of(second, Bob());
  EXPECT_EQ(by_first.Get(kEdgeCallerKey), by_second.Get(kEdgeCallerKey));
  EXPECT_NE(by_first.Get(kEdgeStampKey), by_second.Get(kEdgeStampKey));
  EXPECT_TRUE(second.Verify(by_second.view()).ok());
  // Neither the stamp nor anything derived from the secret is in the
  // message.
  EXPECT_THAT(
      second.Verify(by_first.view()),
      StatusIs(absl::StatusCode::kUnauthenticated,
               AllOf(HasSubstr("x-hdrstereo-edge-stamp does not vouch for "
                               "this caller"),
                     Not(HasSubstr(by_first.Get(kEdgeStampKey))),
                     Not(HasSubstr(by_second.Get(kEdgeStampKey))))));
}

TEST(EdgeStampTest, AStampVouchesForItsOwnCallerOnly) {
  ASSERT_OK_AND_ASSIGN(EdgeStamp stamp, EdgeStamp::Create());
  EdgeCaller admin = Bob();
  admin.principal.role = Role::kAdmin;
  const Metadata bob = Metadata::Of(stamp, Bob());
  const std::string admin_field =
      Metadata::Of(stamp, admin).Get(kEdgeCallerKey);
  EXPECT_THAT(
      stamp.Verify(bob.With(kEdgeCallerKey, admin_field.c_str()).view()),
      StatusIs(absl::StatusCode::kUnauthenticated,
               HasSubstr("or the caller field was altered")));
  // A stamp of the right length but wrong, and one of the wrong length.
  const std::string zeros(bob.Get(kEdgeStampKey).size(), '0');
  EXPECT_THAT(stamp.Verify(bob.With(kEdgeStampKey, zeros.c_str()).view()),
              StatusIs(absl::StatusCode::kUnauthenticated));
  EXPECT_THAT(stamp.Verify(bob.With(kEdgeStampKey, "00").view()),
              StatusIs(absl::StatusCode::kUnauthenticated));
}

TEST(EdgeStampTest, AMissingOrRepeatedKeyIsRefused) {
  ASSERT_OK_AND_ASSIGN(EdgeStamp stamp, EdgeStamp::Create());
  const Metadata bob = Metadata::Of(stamp, Bob());
  EXPECT_THAT(stamp.Verify(Metadata().view()),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("carries no x-hdrstereo-edge-stamp")));
  EXPECT_THAT(stamp.Verify(bob.With(kEdgeStampKey, nullptr).view()),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("carries no x-hdrstereo-edge-stamp")));
  EXPECT_THAT(stamp.Verify(bob.With(kEdgeCallerKey, nullptr).view()),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("but no x-hdrstereo-edge-caller")));
  std::multimap<std::string, std::string> twice = {
      {kEdgeStampKey, bob.Get(kEdgeStampKey)},
      {kEdgeCallerKey, bob.Get(kEdgeCallerKey)},
      {kEdgeCallerKey, bob.Get(kEdgeCallerKey)}};
  EXPECT_THAT(stamp.Verify(Metadata(twice).view()),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("carries x-hdrstereo-edge-caller more than "
                                 "once")));
}

TEST(EdgeStampTest, ACallerBeyondItsLimitsIsRefusedEvenWhenStamped) {
  ASSERT_OK_AND_ASSIGN(EdgeStamp stamp, EdgeStamp::Create());
  auto verify = [&](const EdgeCaller& caller) {
    return stamp.Verify(Metadata::Of(stamp, caller).view()).status();
  };
  EdgeCaller caller = Bob();
  caller.principal.name = "bob\nrole=admin";
  EXPECT_THAT(verify(caller),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("the stamped caller's name: user name "
                                 "\"bob\\nrole=admin\" contains '\\n'")));
  caller.principal.name = std::string(65, 'a');
  EXPECT_THAT(
      verify(caller),
      StatusIs(absl::StatusCode::kUnauthenticated,
               HasSubstr("a user name has 1 to 64 characters, not 65")));
  caller = Bob();
  caller.peer = "ipv4:10.0.0.7:1\x1b[2J";
  EXPECT_THAT(verify(caller),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("the stamped caller's peer "
                                 "\"ipv4:10.0.0.7:1\\x1b[2J\" holds a space "
                                 "or a byte that is not printable ASCII")));
  caller.peer = std::string(257, 'p');
  EXPECT_THAT(verify(caller),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("the stamped caller's peer has 257 bytes; it "
                                 "must have 1 to 256")));
  caller = Bob();
  caller.principal.auth_method = "";
  EXPECT_THAT(verify(caller),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("auth_method has 0 bytes; it must have 1 to "
                                 "64")));
  caller.principal.auth_method = "key x";
  EXPECT_THAT(verify(caller),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("auth_method \"key x\" holds a space")));
  // The whole field is bounded before anything is hashed or decoded.
  caller.principal.auth_method = std::string(2000, 'k');
  EXPECT_THAT(
      verify(caller),
      StatusIs(absl::StatusCode::kUnauthenticated,
               HasSubstr("the x-hdrstereo-edge-caller field has 2752 bytes, "
                         "more than the limit of 1024")));
}

TEST(EdgeStampTest, HasEdgeStampSeesEitherKey) {
  ASSERT_OK_AND_ASSIGN(EdgeStamp stamp, EdgeStamp::Create());
  const Metadata bob = Metadata::Of(stamp, Bob());
  EXPECT_FALSE(HasEdgeStamp(Metadata().view()));
  EXPECT_FALSE(HasEdgeStamp(
      Metadata({{"authorization", "Bearer x"}, {"x-hdrstereo-edge", "1"}})
          .view()));
  EXPECT_TRUE(HasEdgeStamp(bob.With(kEdgeStampKey, nullptr).view()));
  EXPECT_TRUE(HasEdgeStamp(bob.With(kEdgeCallerKey, nullptr).view()));
}

}  // namespace
}  // namespace hdrstereo::rpc
