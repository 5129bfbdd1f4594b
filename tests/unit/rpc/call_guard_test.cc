// SPDX-License-Identifier: GPL-3.0-or-later
//
// CallGuard's decisions, case by case, with the real Authenticator, key
// store, rig lock and audit log on a real SQLite file; the connection's
// AuthContext is a stand-in holding the properties gRPC's TLS and local
// transports set (tests/support/fake_auth_context.h).
// (tests/integration/remote_test.cc drives the same through the real daemon
// with real certificates.)
#include "daemon/rpc/call_guard.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>

#include "daemon/rpc/edge_stamp.h"
#include "tests/support/fake_auth_context.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::rpc {
namespace {

using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

using FakeConnection = ::hdrstereo::testing::FakeAuthContext;

constexpr char kCapture[] = "/hdrstereo.v1.Jobs/SubmitCapture";
constexpr char kInfo[] = "/hdrstereo.v1.Server/GetInfo";
constexpr char kWhoAmI[] = "/hdrstereo.v1.Server/WhoAmI";
constexpr char kMove[] = "/hdrstereo.v1.Hardware/MoveStage";
constexpr char kDelete[] = "/hdrstereo.v1.Sessions/Delete";

class CallGuardTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_OK_AND_ASSIGN(store_, store::Store::Open(dir_ / "data"));
    ASSERT_OK_AND_ASSIGN(keys_, ApiKeyStore::Load(*store_));
    ASSERT_OK_AND_ASSIGN(lock_, jobs::RigLock::Load(*store_));
    audit_ = std::make_unique<AuditLog>(*store_);
    NewGuard({{"alice", Role::kViewer},
              {"bob", Role::kOperator},
              {"carol", Role::kAdmin},
              {"erin", Role::kOperator}},
             Role::kAdmin);
  }

  void NewGuard(RoleMap users, Role local_role) {
    authenticator_ =
        std::make_unique<Authenticator>(std::move(users), local_role, *keys_);
    guard_ = std::make_unique<CallGuard>(*authenticator_, *lock_, *audit_);
  }

  absl::Status Check(const std::string& method,
                     const grpc::AuthContext& connection,
                     std::optional<std::string> authorization = std::nullopt,
                     Principal* principal = nullptr) {
    Principal ignored;
    std::optional<absl::string_view> header;
    if (authorization) header = *authorization;
    return guard_->Check(method, connection, header,
                         principal ? principal : &ignored);
  }

  static FakeConnection Cert(const std::string& user) {
    return FakeConnection::Certificate("hdrstereo://user/" + user, user);
  }

  testing::TempDir dir_;
  std::unique_ptr<store::Store> store_;
  std::unique_ptr<ApiKeyStore> keys_;
  std::unique_ptr<jobs::RigLock> lock_;
  std::unique_ptr<AuditLog> audit_;
  std::unique_ptr<Authenticator> authenticator_;
  std::unique_ptr<CallGuard> guard_;
};

TEST_F(CallGuardTest, LocalCallersHaveTheLocalRole) {
  Principal who;
  EXPECT_THAT(Check(kDelete, FakeConnection::Local(), std::nullopt, &who),
              IsOk());
  EXPECT_EQ(who.name, "local");
  EXPECT_EQ(who.auth_method, "local");
  NewGuard({}, Role::kViewer);
  EXPECT_THAT(Check(kInfo, FakeConnection::Local()), IsOk());
  EXPECT_THAT(Check(kCapture, FakeConnection::Local()),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       HasSubstr("needs role operator; local has viewer")));
}

TEST_F(CallGuardTest, CertificatesNameTheirPrincipalAndConfigGivesTheRole) {
  Principal who;
  EXPECT_THAT(Check(kInfo, Cert("alice"), std::nullopt, &who), IsOk());
  EXPECT_EQ(who.name, "alice");
  EXPECT_EQ(who.role, Role::kViewer);
  EXPECT_EQ(who.auth_method, "cert");
  EXPECT_THAT(Check(kCapture, Cert("alice")),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       HasSubstr("/hdrstereo.v1.Jobs/SubmitCapture needs role "
                                 "operator; alice has viewer")));
  EXPECT_THAT(Check(kCapture, Cert("bob")), IsOk());
  EXPECT_THAT(Check(kDelete, Cert("bob")),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       HasSubstr("needs role admin; bob has operator")));
  EXPECT_THAT(Check(kDelete, Cert("carol")), IsOk());
  // The SAN URI wins over the CN; without it, the CN names the principal.
  EXPECT_THAT(
      Check(kDelete,
            FakeConnection::Certificate("hdrstereo://user/alice", "carol"),
            std::nullopt, &who),
      StatusIs(absl::StatusCode::kPermissionDenied));
  EXPECT_EQ(who.name, "alice");
  EXPECT_THAT(Check(kDelete, FakeConnection::Certificate("", "carol")), IsOk());
  EXPECT_THAT(Check(kDelete, FakeConnection::Certificate("", "carol", "ssl")),
              IsOk());
}

TEST_F(CallGuardTest, AnUnknownTransportIsRefused) {
  for (const char* transport : {"insecure", "", "alts"}) {
    EXPECT_THAT(Check(kWhoAmI, FakeConnection::Transport(transport)),
                StatusIs(absl::StatusCode::kUnauthenticated,
                         HasSubstr("is not one hdrstereod serves")))
        << transport;
  }
}

TEST_F(CallGuardTest, APrincipalWithoutARoleMayOnlyAskWhoItIs) {
  EXPECT_THAT(Check(kWhoAmI, Cert("dave")), IsOk());
  EXPECT_THAT(Check(kInfo, Cert("dave")),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       HasSubstr("dave has no role (an admin gives one in "
                                 "[auth.users]")));
}

TEST_F(CallGuardTest, TlsWithoutCertificateOrKeyIsUnauthenticated) {
  EXPECT_THAT(Check(kWhoAmI, FakeConnection::Tls()),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("no client certificate and no API key")));
  EXPECT_THAT(
      Check(kInfo, FakeConnection::Certificate("", "two words")),
      StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("contains ' '")));
}

TEST_F(CallGuardTest, ApiKeysWorkOverTlsOnlyAndAreCappedByTheirUsersRole) {
  ASSERT_OK_AND_ASSIGN(
      NewApiKey key,
      keys_->Create("bob", Role::kOperator, absl::Hours(1), "", "carol"));
  const std::string bearer = "Bearer " + key.token;
  Principal who;
  EXPECT_THAT(Check(kCapture, FakeConnection::Tls(), bearer, &who), IsOk());
  EXPECT_EQ(who.name, "bob");
  EXPECT_EQ(who.auth_method, "key:" + key.record.id);
  EXPECT_TRUE(who.key_expire_time.has_value());
  // Over a certificate connection, the key names the caller.
  EXPECT_THAT(Check(kCapture, Cert("alice"), bearer, &who), IsOk());
  EXPECT_EQ(who.name, "bob");
  // Not on a local (plaintext) connection, even though local is admin.
  EXPECT_THAT(Check(kInfo, FakeConnection::Local(), bearer, &who),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("accepted over TLS only")));
  EXPECT_EQ(who.auth_method, "key:" + key.record.id);
  EXPECT_THAT(Check(kInfo, FakeConnection::Tls(), key.token),
              StatusIs(absl::StatusCode::kUnauthenticated,
                       HasSubstr("must be \"Bearer hs_<id>_<secret>\"")));
  EXPECT_THAT(Check(kInfo, FakeConnection::Tls(), "Bearer nonsense"),
              StatusIs(absl::StatusCode::kUnauthenticated));
  // bob demoted in the config: his operator key is a viewer key now.
  NewGuard({{"bob", Role::kViewer}}, Role::kAdmin);
  EXPECT_THAT(Check(kCapture, FakeConnection::Tls(), bearer),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       HasSubstr("bob has viewer")));
  // bob removed: no role at all.
  NewGuard({}, Role::kAdmin);
  EXPECT_THAT(Check(kInfo, FakeConnection::Tls(), bearer),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       HasSubstr("bob has no role")));
}

TEST_F(CallGuardTest, UnknownMethodsAreRefusedAfterAuthentication) {
  EXPECT_THAT(
      Check("/hdrstereo.v1.Jobs/Explode", Cert("carol")),
      StatusIs(absl::StatusCode::kUnimplemented,
               HasSubstr("serves no method /hdrstereo.v1.Jobs/Explode")));
  EXPECT_THAT(Check("/hdrstereo.v1.Jobs/Explode", FakeConnection::Tls()),
              StatusIs(absl::StatusCode::kUnauthenticated));
  EXPECT_THAT(Check("", FakeConnection::Local()),
              StatusIs(absl::StatusCode::kUnimplemented));
}

TEST_F(CallGuardTest, TheRigLockKeepsOtherPrincipalsOffTheRig) {
  ASSERT_THAT(
      lock_->Acquire("bob", "re-aligning the projector", absl::Hours(1)),
      IsOk());
  EXPECT_THAT(Check(kMove, Cert("bob")), IsOk());
  EXPECT_THAT(Check(kCapture, Cert("bob")), IsOk());
  EXPECT_THAT(Check(kMove, Cert("erin")),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("locked by bob until ")));
  EXPECT_THAT(Check(kCapture, Cert("carol")),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr(": re-aligning the projector")));
  // Reading and jobs that do not use the rig go on.
  EXPECT_THAT(Check("/hdrstereo.v1.Hardware/GetStatus", Cert("erin")), IsOk());
  EXPECT_THAT(Check("/hdrstereo.v1.Jobs/SubmitProcessing", Cert("erin")),
              IsOk());
  // The role is checked before the lock.
  EXPECT_THAT(Check(kMove, Cert("alice")),
              StatusIs(absl::StatusCode::kPermissionDenied));
}

TEST_F(CallGuardTest, EveryRefusalIsAudited) {
  grpc::AuthMetadataProcessor::InputMetadata metadata;
  grpc::AuthMetadataProcessor::OutputMetadata consumed, response;
  metadata.emplace(":path", kCapture);
  FakeConnection alice = Cert("alice");
  grpc::Status refused =
      guard_->Process(metadata, &alice, &consumed, &response);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_THAT(refused.error_message(), HasSubstr("needs role operator"));
  FakeConnection bob = Cert("bob");
  EXPECT_TRUE(guard_->Process(metadata, &bob, &consumed, &response).ok());
  FakeConnection anonymous = FakeConnection::Tls();
  EXPECT_EQ(
      guard_->Process(metadata, &anonymous, &consumed, &response).error_code(),
      grpc::StatusCode::UNAUTHENTICATED);

  audit_->Flush();
  ASSERT_OK_AND_ASSIGN(std::vector<store::AuditRecord> rows,
                       audit_->repository().List({}));
  ASSERT_EQ(rows.size(), 2u);  // the allowed call is the interceptor's
  EXPECT_EQ(rows[0].principal, "");
  EXPECT_EQ(rows[0].status_code,
            static_cast<int>(absl::StatusCode::kUnauthenticated));
  EXPECT_EQ(rows[1].principal, "alice");
  EXPECT_EQ(rows[1].role, "viewer");
  EXPECT_EQ(rows[1].auth_method, "cert");
  EXPECT_EQ(rows[1].transport, "grpc");
  EXPECT_EQ(rows[1].method, kCapture);
  EXPECT_EQ(rows[1].status_code,
            static_cast<int>(absl::StatusCode::kPermissionDenied));
  EXPECT_THAT(rows[1].message, HasSubstr("needs role operator"));
}

// Only in-process calls may carry the HTTP edge's stamp: on a network port
// either of its keys gets the call refused, whoever makes it, and audited
// naming who tried.
TEST_F(CallGuardTest, TheHttpEdgesStampIsRefusedOnTheNetwork) {
  grpc::AuthMetadataProcessor::OutputMetadata consumed, response;
  FakeConnection carol = Cert("carol");
  FakeConnection local = FakeConnection::Local();
  for (const char* key : {kEdgeStampKey, kEdgeCallerKey}) {
    for (FakeConnection* connection : {&carol, &local}) {
      grpc::AuthMetadataProcessor::InputMetadata metadata;
      metadata.emplace(":path", kWhoAmI);
      metadata.emplace(key, "forged");
      grpc::Status refused =
          guard_->Process(metadata, connection, &consumed, &response);
      EXPECT_EQ(refused.error_code(), grpc::StatusCode::UNAUTHENTICATED) << key;
      EXPECT_THAT(refused.error_message(),
                  HasSubstr("are set only by hdrstereod's own HTTP edge"));
      Principal who;
      EXPECT_THAT(
          guard_->CheckNetworkCall(kWhoAmI, *connection, metadata, &who),
          StatusIs(absl::StatusCode::kUnauthenticated,
                   HasSubstr("a call over the network may not carry "
                             "them")));
    }
  }
  audit_->Flush();
  ASSERT_OK_AND_ASSIGN(std::vector<store::AuditRecord> rows,
                       audit_->repository().List({}));
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[3].principal, "carol");
  EXPECT_EQ(rows[3].auth_method, "cert");
  EXPECT_EQ(rows[2].principal, "local");
  for (const store::AuditRecord& row : rows) {
    EXPECT_EQ(row.transport, "grpc");
    EXPECT_EQ(row.method, kWhoAmI);
    EXPECT_EQ(row.status_code,
              static_cast<int>(absl::StatusCode::kUnauthenticated));
  }
}

// What the guard's interceptor asks for a caller the HTTP edge stamped:
// the role table and the rig lock, as for any other caller.
TEST_F(CallGuardTest, AuthorizeAppliesTheRoleTableAndTheRigLock) {
  const Principal bob = {.name = "bob",
                         .role = Role::kOperator,
                         .auth_method = "key:0a1b2c3d4e5f",
                         .key_expire_time = std::nullopt};
  EXPECT_THAT(guard_->Authorize(kMove, bob), IsOk());
  EXPECT_THAT(guard_->Authorize(kDelete, bob),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       HasSubstr("/hdrstereo.v1.Sessions/Delete needs role "
                                 "admin; bob has operator")));
  EXPECT_THAT(guard_->Authorize("/hdrstereo.v1.Jobs/Explode", bob),
              StatusIs(absl::StatusCode::kUnimplemented));
  ASSERT_THAT(lock_->Acquire("erin", "focusing", absl::Hours(1)), IsOk());
  EXPECT_THAT(guard_->Authorize(kMove, bob),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("locked by erin until ")));
}

}  // namespace
}  // namespace hdrstereo::rpc
