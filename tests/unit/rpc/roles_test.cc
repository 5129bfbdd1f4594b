// SPDX-License-Identifier: GPL-3.0-or-later
//
// Role names and principal names as the configuration and the RPC edge
// spell them; what a peer sent reaches a message escaped and bounded.
#include "daemon/rpc/roles.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "tests/support/status_matchers.h"

namespace hdrstereo::rpc {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

TEST(RolesTest, RoleNamesReadBack) {
  for (Role role :
       {Role::kNone, Role::kViewer, Role::kOperator, Role::kAdmin}) {
    ASSERT_OK_AND_ASSIGN(const Role parsed, ParseRole(RoleName(role)));
    EXPECT_EQ(parsed, role);
  }
  EXPECT_THAT(ParseRole("root"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("\"root\" is not a role: use viewer, "
                                 "operator or admin")));
}

TEST(RolesTest, AnUnknownRoleIsQuotedEscapedAndBounded) {
  EXPECT_THAT(ParseRole("admin\x1b[2J"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("\"admin\\x1b[2J\" is not a role"),
                             Not(HasSubstr("\x1b")))));
  const absl::StatusOr<Role> role = ParseRole(std::string(100000, 'r'));
  EXPECT_THAT(role, StatusIs(absl::StatusCode::kInvalidArgument,
                             HasSubstr("\"... (100000 bytes) is not a role")));
  EXPECT_LT(role.status().message().size(), 200u);
}

TEST(RolesTest, PrincipalNamesAreLettersDigitsAndFourMarks) {
  EXPECT_TRUE(ValidatePrincipalName("alice.b_c@lab-1", "cert").ok());
  EXPECT_THAT(ValidatePrincipalName("", "cert"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("cert: a user name has 1 to 64 characters, "
                                 "not 0")));
  EXPECT_THAT(ValidatePrincipalName(std::string(65, 'a'), "cert"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("1 to 64 characters, not 65")));
  EXPECT_THAT(
      ValidatePrincipalName("two words", "cert"),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("cert: user name \"two words\" contains ' '; "
                         "use letters, digits, '.', '_', '@' and '-'")));
}

// The name and its bad character are escaped: a control character or a
// byte of another encoding does not reach a log or a terminal as it is.
TEST(RolesTest, ABadCharacterIsEscaped) {
  EXPECT_THAT(
      ValidatePrincipalName("eve\x1b]0;x\a", "api key"),
      StatusIs(absl::StatusCode::kInvalidArgument,
               AllOf(HasSubstr("api key: user name \"eve\\x1b]0;x\\x07\" "
                               "contains '\\x1b'"),
                     Not(HasSubstr("\x1b")), Not(HasSubstr("\a")))));
  EXPECT_THAT(ValidatePrincipalName("caf\xc3\xa9", "cert"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("user name \"caf\\xc3\\xa9\" contains "
                                 "'\\xc3'")));
}

}  // namespace
}  // namespace hdrstereo::rpc
