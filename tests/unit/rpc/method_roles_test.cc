// SPDX-License-Identifier: GPL-3.0-or-later
//
// The role table against the wire contract: every method of every service
// in proto/hdrstereo/v1 (read from the generated descriptor pool) has an
// entry, so a new RPC cannot ship unprotected; and the entries are the
// roles DESIGN.md and the remote-operation issue give.
#include "daemon/rpc/method_roles.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "tests/support/proto_methods.h"

namespace hdrstereo::rpc {
namespace {

using ::testing::IsEmpty;

std::vector<std::string> AllMethods() {
  std::vector<std::string> names;
  for (const testing::ProtoMethod& method : testing::AllProtoMethods()) {
    names.push_back(method.full_name);
  }
  return names;
}

TEST(MethodRolesTest, EveryMethodOfEveryServiceHasAnEntry) {
  const std::vector<std::string> methods = AllMethods();
  // Six services with 39 methods as this test was last extended; fewer
  // means the walk is broken.
  ASSERT_GE(methods.size(), 39u);
  std::vector<std::string> missing;
  for (const std::string& method : methods) {
    if (FindMethodRule(method) == nullptr) missing.push_back(method);
  }
  EXPECT_THAT(missing, IsEmpty()) << "add these to daemon/rpc/method_roles.cc";
}

TEST(MethodRolesTest, TheTableHasNoEntryForAMethodNobodyServes) {
  const std::vector<std::string> methods = AllMethods();
  const std::set<std::string> served(methods.begin(), methods.end());
  const std::set<std::string> plugins = {
      "/grpc.health.v1.Health/Check", "/grpc.health.v1.Health/Watch",
      "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo"};
  for (const auto& [method, rule] : MethodRules()) {
    EXPECT_TRUE(served.count(method) == 1 || plugins.count(method) == 1)
        << method << " is in the table but in no .proto";
  }
}

TEST(MethodRolesTest, ServedServicesCheckFindsAMissingMethod) {
  EXPECT_THAT(MethodsWithoutRule({"hdrstereo.v1.Jobs", "hdrstereo.v1.Admin"}),
              IsEmpty());
  EXPECT_THAT(MethodsWithoutRule({"hdrstereo.v1.NoSuchService"}),
              ::testing::ElementsAre("hdrstereo.v1.NoSuchService"));
}

TEST(MethodRolesTest, RolesAreTheOnesTheIssueGives) {
  struct Row {
    const char* method;
    Role role;
    bool mutating;
    bool uses_rig;
  };
  const Row rows[] = {
      {"/hdrstereo.v1.Server/WhoAmI", Role::kNone, false, false},
      {"/hdrstereo.v1.Server/GetInfo", Role::kViewer, false, false},
      {"/grpc.health.v1.Health/Check", Role::kViewer, false, false},
      {"/hdrstereo.v1.Hardware/GetStatus", Role::kViewer, false, false},
      {"/hdrstereo.v1.Hardware/GetCameraSettings", Role::kViewer, false, false},
      {"/hdrstereo.v1.Sessions/DownloadArtifact", Role::kViewer, false, false},
      {"/hdrstereo.v1.Sessions/DownloadFrame", Role::kViewer, false, false},
      {"/hdrstereo.v1.Jobs/Watch", Role::kViewer, false, false},
      {"/hdrstereo.v1.Schedules/ListRuns", Role::kViewer, false, false},
      {"/hdrstereo.v1.Sessions/Create", Role::kOperator, true, false},
      {"/hdrstereo.v1.Jobs/SubmitCapture", Role::kOperator, true, true},
      {"/hdrstereo.v1.Jobs/SubmitProcessing", Role::kOperator, true, false},
      {"/hdrstereo.v1.Jobs/Cancel", Role::kOperator, true, false},
      {"/hdrstereo.v1.Jobs/Continue", Role::kOperator, true, false},
      {"/hdrstereo.v1.Hardware/MoveStage", Role::kOperator, true, true},
      {"/hdrstereo.v1.Hardware/ShowPattern", Role::kOperator, true, true},
      {"/hdrstereo.v1.Hardware/SetCameraSettings", Role::kOperator, true, true},
      // Live view drives the camera but records nothing.
      {"/hdrstereo.v1.Hardware/StreamPreview", Role::kOperator, false, true},
      {"/hdrstereo.v1.Hardware/ProbeProjector", Role::kOperator, true, true},
      {"/hdrstereo.v1.Hardware/Lock", Role::kOperator, true, false},
      {"/hdrstereo.v1.Hardware/Unlock", Role::kOperator, true, false},
      {"/hdrstereo.v1.Sessions/Delete", Role::kAdmin, true, false},
      {"/hdrstereo.v1.Schedules/Create", Role::kAdmin, true, false},
      {"/hdrstereo.v1.Schedules/SetEnabled", Role::kAdmin, true, false},
      {"/hdrstereo.v1.Admin/CreateApiKey", Role::kAdmin, true, false},
      {"/hdrstereo.v1.Admin/ListAuditLog", Role::kAdmin, false, false},
  };
  for (const Row& row : rows) {
    const MethodRule* rule = FindMethodRule(row.method);
    ASSERT_NE(rule, nullptr) << row.method;
    EXPECT_EQ(rule->min_role, row.role) << row.method;
    EXPECT_EQ(rule->mutating, row.mutating) << row.method;
    EXPECT_EQ(rule->uses_rig, row.uses_rig) << row.method;
  }
  EXPECT_EQ(FindMethodRule("/hdrstereo.v1.Jobs/Nope"), nullptr);
  EXPECT_EQ(FindMethodRule(""), nullptr);
}

}  // namespace
}  // namespace hdrstereo::rpc
