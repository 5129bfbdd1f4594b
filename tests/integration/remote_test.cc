// SPDX-License-Identifier: GPL-3.0-or-later
//
// Remote operation end to end: the real daemon listening on
// 0.0.0.0:<free port> with TLS and real certificates (deploy/make-certs.sh),
// the real CLI and plain gRPC clients connecting to 127.0.0.1. The role
// table at every boundary, every transport failure, API keys, the audit log
// and the rig lock. Every test checks that what was refused changed
// nothing.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "daemon/rpc/edge_stamp.h"
#include "daemon/rpc/method_roles.h"
#include "hdrstereo/v1/admin.grpc.pb.h"
#include "hdrstereo/v1/hardware.grpc.pb.h"
#include "hdrstereo/v1/server.grpc.pb.h"
#include "hdrstereo/v1/sessions.grpc.pb.h"
#include "tests/integration/remote_fixture.h"
#include "tests/support/proto_methods.h"
#include "tests/support/role_outcomes.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::hdrstereo::testing::JsonInt;
using ::hdrstereo::testing::ReadFileOrDie;
using ::hdrstereo::testing::RunCommand;
using ::testing::HasSubstr;
using ::testing::Not;

class RemoteTest : public testing::RemoteFixture {
 protected:
  // The audit log as the admin reads it, oldest first.
  std::vector<nlohmann::json> Audit(std::vector<std::string> filter = {}) {
    filter.insert(filter.begin(), {"audit", "--limit", "1000"});
    nlohmann::json log = AsJson("carol", filter);
    std::vector<nlohmann::json> entries;
    for (const nlohmann::json& e :
         log.value("entries", nlohmann::json::array())) {
      entries.insert(entries.begin(), e);
    }
    return entries;
  }

  static bool Has(const std::vector<nlohmann::json>& entries,
                  const std::string& principal, const std::string& method,
                  int code) {
    for (const nlohmann::json& e : entries) {
      if (e.value("principal", "") == principal &&
          e.value("method", "") == method &&
          e.value("status_code", -1) == code) {
        return true;
      }
    }
    return false;
  }

  std::string PlanFile() {
    const fs::path path = dir_ / "plan.json";
    std::ofstream(path) << R"({"sessionPattern": "sched-{date}-{time}",
      "captures": [{"bracketedStereo": {"exposuresS": [0.01]}}]})";
    return path.string();
  }
};

constexpr int kOk = 0;
constexpr int kUnauthenticated = 16;
constexpr int kPermissionDenied = 7;
constexpr int kFailedPrecondition = 9;

TEST_F(RemoteTest, EveryRoleBoundaryThroughTheCli) {
  StartTlsDaemon();
  // viewer: reads, and is refused a capture.
  ASSERT_EQ(As("carol", {"session", "create", "s1"}).exit_code, 0);
  CommandResult list = As("alice", {"session", "list"});
  EXPECT_EQ(list.exit_code, 0) << list.err;
  EXPECT_THAT(list.out, HasSubstr("s1"));
  CommandResult refused =
      As("alice", {"capture", "stereo", "s1", "--exposures", "1/100"});
  EXPECT_EQ(refused.exit_code, 6);
  EXPECT_THAT(refused.err,
              HasSubstr("permission denied: /hdrstereo.v1.Jobs/SubmitCapture "
                        "needs role operator; alice has viewer"));
  // operator: captures; is refused deleting a session and making a schedule.
  nlohmann::json job = AsJson("bob", {"capture", "stereo", "s1", "--exposures",
                                      "1/100", "--no-ambient"});
  const int64_t job_id = JsonInt(job["id"]);
  ASSERT_GT(job_id, 0);
  EXPECT_EQ(job.value("submitted_by", ""), "bob");
  CommandResult no_delete = As("bob", {"session", "delete", "s1", "--yes"});
  EXPECT_EQ(no_delete.exit_code, 6);
  EXPECT_THAT(no_delete.err, HasSubstr("Sessions/Delete needs role admin; bob "
                                       "has operator"));
  CommandResult no_schedule = As("bob", {"schedule", "add", "n", "--cron",
                                         "0 3 * * *", "--plan", PlanFile()});
  EXPECT_EQ(no_schedule.exit_code, 6);
  EXPECT_THAT(no_schedule.err, HasSubstr("Schedules/Create needs role admin"));
  cli_args_ = certs_.CliArgs("bob");
  ASSERT_TRUE(WaitForJobState(job_id, "succeeded")) << daemon_log();
  cli_args_.clear();
  EXPECT_EQ(AsJson("alice", {"jobs", "show", absl::StrCat(job_id)})
                .value("submitted_by", ""),
            "bob");
  // admin: both.
  ASSERT_EQ(As("carol", {"schedule", "add", "n", "--cron", "0 3 * * *",
                         "--plan", PlanFile()})
                .exit_code,
            0);
  nlohmann::json schedules = AsJson("alice", {"schedule", "list"});
  EXPECT_EQ(schedules["schedules"][0].value("created_by", ""), "carol");
  ASSERT_EQ(As("carol", {"session", "create", "s2"}).exit_code, 0);
  CommandResult deleted = As("carol", {"session", "delete", "s2", "--yes"});
  EXPECT_EQ(deleted.exit_code, 0) << deleted.err;
  // No role: only whoami.
  CommandResult whoami = As("dave", {"whoami"});
  EXPECT_EQ(whoami.exit_code, 0) << whoami.err;
  EXPECT_THAT(whoami.out, HasSubstr("principal  dave"));
  EXPECT_THAT(whoami.out, HasSubstr("none (every call but whoami is refused)"));
  EXPECT_THAT(whoami.out, HasSubstr("auth       cert"));
  for (std::vector<std::string> args :
       {std::vector<std::string>{"session", "list"},
        std::vector<std::string>{"status"},
        std::vector<std::string>{"jobs", "show", absl::StrCat(job_id)}}) {
    CommandResult dave = As("dave", args);
    EXPECT_EQ(dave.exit_code, 6) << args[0];
    EXPECT_THAT(dave.err, HasSubstr("dave has no role"));
  }

  // What was refused changed nothing; what was done is on record.
  EXPECT_EQ(Sql("SELECT group_concat(name) FROM sessions"), "s1");
  EXPECT_EQ(Sql("SELECT count(*) FROM schedules"), "1");
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs"), "1");
  EXPECT_EQ(Sql("SELECT submitted_by FROM jobs"), "bob");
  const std::vector<nlohmann::json> audit = Audit();
  EXPECT_TRUE(Has(audit, "alice", "/hdrstereo.v1.Jobs/SubmitCapture",
                  kPermissionDenied));
  EXPECT_TRUE(Has(audit, "bob", "/hdrstereo.v1.Jobs/SubmitCapture", kOk));
  EXPECT_TRUE(
      Has(audit, "bob", "/hdrstereo.v1.Sessions/Delete", kPermissionDenied));
  EXPECT_TRUE(Has(audit, "carol", "/hdrstereo.v1.Sessions/Delete", kOk));
  EXPECT_TRUE(Has(audit, "carol", "/hdrstereo.v1.Schedules/Create", kOk));
  EXPECT_TRUE(
      Has(audit, "dave", "/hdrstereo.v1.Sessions/List", kPermissionDenied));
  for (const nlohmann::json& e : audit) {
    if (e.value("principal", "") == "bob" &&
        e.value("method", "") == "/hdrstereo.v1.Jobs/SubmitCapture") {
      EXPECT_EQ(e.value("subject", ""),
                absl::StrCat("session s1, job ", job_id));
      EXPECT_EQ(e.value("role", ""), "ROLE_OPERATOR");
      EXPECT_EQ(e.value("auth_method", ""), "cert");
      EXPECT_THAT(e.value("peer", ""), HasSubstr("127.0.0.1:"));
    }
  }
  // Allowed reads are not audited; the principal filter filters.
  EXPECT_EQ(Sql("SELECT count(*) FROM audit WHERE principal = 'alice' AND "
                "status_code = 0"),
            "0");
  for (const nlohmann::json& e : Audit({"--principal", "alice"})) {
    EXPECT_EQ(e.value("principal", ""), "alice");
  }
  EXPECT_EQ(Audit({"--since", "1h"}).size(), audit.size());
  EXPECT_TRUE(Audit({"--until", "2000-01-01"}).empty());
  // Pages: newest first, no row twice, none left out.
  auto admin = v1::Admin::NewStub(TlsChannel("carol"));
  v1::ListAuditLogRequest request;
  request.mutable_page()->set_page_size(2);
  std::vector<int64_t> ids;
  for (int page = 0; page < 100; ++page) {
    v1::ListAuditLogResponse response;
    grpc::ClientContext context;
    ASSERT_TRUE(admin->ListAuditLog(&context, request, &response).ok());
    EXPECT_LE(response.entries_size(), 2);
    for (const v1::AuditEntry& e : response.entries()) ids.push_back(e.id());
    if (response.next_page_token().empty()) break;
    request.mutable_page()->set_page_token(response.next_page_token());
  }
  EXPECT_TRUE(std::is_sorted(ids.rbegin(), ids.rend()));
  EXPECT_EQ(std::set<int64_t>(ids.begin(), ids.end()).size(), ids.size());
  EXPECT_GE(ids.size(), audit.size());  // and the reads of it since
  v1::ListAuditLogRequest backwards;
  backwards.mutable_start_time()->set_seconds(2000000000);
  backwards.mutable_end_time()->set_seconds(1000000000);
  v1::ListAuditLogResponse none;
  grpc::ClientContext context;
  grpc::Status bad = admin->ListAuditLog(&context, backwards, &none);
  EXPECT_EQ(bad.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(bad.error_message(), HasSubstr("end_time must be after"));
  EXPECT_EQ(StopDaemon(), 0);
}

// Every method of every hdrstereo.v1 service, called with an empty request
// through the real TLS server: without credentials, as a principal without
// a role, and at each role (an empty request changes nothing that the
// handlers' validation lets through on the simulated rig).
TEST_F(RemoteTest, EveryMethodIsGuardedBeforeItsHandler) {
  StartTlsDaemon();
  auto anonymous = TlsChannel("");
  auto dave = TlsChannel("dave");
  const std::vector<std::pair<std::string, rpc::Role>> roles = {
      {"alice", rpc::Role::kViewer},
      {"bob", rpc::Role::kOperator},
      {"carol", rpc::Role::kAdmin}};
  std::map<std::string, std::shared_ptr<grpc::Channel>> channels;
  for (const auto& [user, role] : roles) channels[user] = TlsChannel(user);
  const std::vector<testing::ProtoMethod> methods = testing::AllProtoMethods();
  ASSERT_GE(methods.size(), 37u);
  for (const testing::ProtoMethod& method : methods) {
    const std::string& name = method.full_name;
    grpc::Status none = Call(anonymous, name);
    EXPECT_EQ(none.error_code(), grpc::StatusCode::UNAUTHENTICATED) << name;
    testing::ExpectRoleOutcome(name, "dave", rpc::Role::kNone,
                               Call(dave, name));
    // An allowed stream (live view) goes on until its deadline: a unary
    // call reads one message of it.
    const absl::Duration deadline = method.descriptor->server_streaming()
                                        ? absl::Seconds(3)
                                        : absl::Seconds(20);
    for (const auto& [user, role] : roles) {
      testing::ExpectRoleOutcome(name, user, role,
                                 Call(channels[user], name, nullptr, deadline));
    }
  }
  // Nothing was created by the refused calls (empty requests would be
  // refused by validation anyway; the handlers did not run).
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM api_keys"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM rig_lock"), "0");
  EXPECT_EQ(StopDaemon(), 0);
}

// The HTTP edge's stamp names the caller of an in-process call only: a call
// over the network carrying its metadata is refused before any handler,
// even with an admin's valid client certificate or on the local port, and
// each refusal is audited once, naming who tried.
TEST_F(RemoteTest, ANetworkCallCarryingTheHttpEdgesStampIsRefused) {
  StartTlsDaemon({}, /*local_port=*/true);
  const std::vector<std::pair<std::string, std::shared_ptr<grpc::Channel>>>
      callers = {
          {"carol", TlsChannel("carol")},
          {"local", grpc::CreateChannel(local_address(),
                                        grpc::InsecureChannelCredentials())}};
  // Well formed: a stamp-sized value and carol as admin, base64 fields.
  const std::string stamp(64, 'a');
  const std::string caller = "Y2Fyb2w.YWRtaW4.Y2VydA.aXB2NDoxLjIuMy40OjU.";
  int refused = 0;
  for (const auto& [who, channel] : callers) {
    for (const bool with_stamp : {true, false}) {
      grpc::ClientContext context;
      if (with_stamp) context.AddMetadata(rpc::kEdgeStampKey, stamp);
      context.AddMetadata(rpc::kEdgeCallerKey, caller);
      v1::CreateSessionRequest request;
      request.set_name("smuggled");
      v1::Session session;
      grpc::Status status =
          v1::Sessions::NewStub(channel)->Create(&context, request, &session);
      ++refused;
      EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << who;
      EXPECT_THAT(status.error_message(),
                  HasSubstr("x-hdrstereo-edge-stamp and "
                            "x-hdrstereo-edge-caller are set only by "
                            "hdrstereod's own HTTP edge"))
          << who;
    }
  }
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  int audited = 0;
  for (const nlohmann::json& e :
       Audit({"--method", "/hdrstereo.v1.Sessions/Create"})) {
    ++audited;
    EXPECT_EQ(e.value("status_code", -1), kUnauthenticated);
    EXPECT_EQ(e.value("transport", ""), "grpc");
    EXPECT_THAT(e.value("message", ""),
                HasSubstr("set only by hdrstereod's own HTTP edge"));
    EXPECT_THAT(e.value("principal", ""), ::testing::AnyOf("carol", "local"));
  }
  EXPECT_EQ(audited, refused);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(RemoteTest, TransportFailuresAreClearAndChangeNothing) {
  StartTlsDaemon({}, /*local_port=*/true);
  // A plaintext client on the TLS port.
  CommandResult plain = Cli({"session", "create", "x"});
  EXPECT_EQ(plain.exit_code, 3);
  EXPECT_THAT(plain.err, HasSubstr("cannot reach hdrstereod at " + address_));
  EXPECT_THAT(plain.err, HasSubstr("if hdrstereod serves TLS there, connect "
                                   "with --tls-ca"));
  // A TLS client on the plaintext port.
  std::vector<std::string> bob = certs_.CliArgs("bob");
  std::vector<std::string> args = {HDRSTEREO_CLI, "--server", local_address()};
  args.insert(args.end(), bob.begin(), bob.end());
  args.insert(args.end(), {"session", "create", "x"});
  absl::StatusOr<CommandResult> tls_on_plain = RunCommand(args);
  ASSERT_TRUE(tls_on_plain.ok());
  EXPECT_EQ(tls_on_plain->exit_code, 3);
  EXPECT_THAT(tls_on_plain->err, HasSubstr("over TLS: is it hdrstereod's TLS "
                                           "port"));
  // Certificates the daemon must not accept, and a daemon the client must
  // not trust.
  for (const char* user : {"expired", "future", "revoked", "mallory"}) {
    CommandResult result = As(user, {"session", "create", "x"});
    EXPECT_EQ(result.exit_code, 3) << user << ": " << result.err;
    EXPECT_THAT(result.err, HasSubstr("cannot reach hdrstereod")) << user;
  }
  std::vector<std::string> rogue = {"--tls-ca",   certs_.rogue_ca().string(),
                                    "--tls-cert", certs_.Cert("bob").string(),
                                    "--tls-key",  certs_.Key("bob").string(),
                                    "session",    "create",
                                    "x"};
  EXPECT_EQ(Cli(rogue).exit_code, 3);
  // TLS without a certificate or key.
  CommandResult anonymous = As("", {"session", "create", "x"});
  EXPECT_EQ(anonymous.exit_code, 5);
  EXPECT_THAT(anonymous.err, HasSubstr("no client certificate and no API key"));

  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  // The daemon serves on: the same certificates' owners get in.
  EXPECT_EQ(As("bob", {"session", "create", "x"}).exit_code, 0);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(RemoteTest, BadTlsConfigurationIsRefusedAtStartNamingTheFile) {
  const fs::path copy = dir_ / "open.key";
  fs::copy_file(certs_.server_key(), copy);
  ::chmod(copy.c_str(), 0644);
  struct Case {
    std::vector<std::string> tls;
    std::string message;
  };
  const std::string cert = certs_.server_cert().string();
  const std::string key = certs_.server_key().string();
  const std::string ca = certs_.ca().string();
  const std::string missing = (dir_ / "missing.key").string();
  const Case cases[] = {
      {{"--tls-cert", cert, "--tls-key", missing, "--tls-client-ca", ca},
       "--tls-key " + missing + ": cannot read it"},
      {{"--tls-cert", cert, "--tls-key", certs_.Key("alice").string(),
        "--tls-client-ca", ca},
       "does not match the certificate in --tls-cert " + cert},
      {{"--tls-cert", cert, "--tls-key", key, "--tls-client-ca", key},
       "--tls-client-ca " + key + " holds no PEM certificate"},
      {{"--tls-cert", key, "--tls-key", key, "--tls-client-ca", ca},
       "--tls-cert " + key + " holds no PEM certificate"},
      {{"--tls-cert", cert, "--tls-key", copy.string(), "--tls-client-ca", ca},
       "is readable by every user on this machine; chmod o-r it"},
      {{"--tls-cert", certs_.Cert("expired").string(), "--tls-key",
        certs_.Key("expired").string(), "--tls-client-ca", ca},
       "the certificate has expired"},
      {{"--tls-cert", cert, "--tls-key", key, "--tls-client-ca", ca,
        "--tls-crl-dir", missing},
       "--tls-crl-dir " + missing + " is not a folder"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> argv = {HDRSTEREOD,
                                     "--listen",
                                     "0.0.0.0:0",
                                     "--data-root",
                                     data_root().string(),
                                     "--log-file",
                                     (dir_ / "refused.log").string()};
    argv.insert(argv.end(), c.tls.begin(), c.tls.end());
    absl::StatusOr<CommandResult> result = RunCommand(argv);
    ASSERT_TRUE(result.ok());
    EXPECT_EQ(result->exit_code, 1) << c.message;
    EXPECT_THAT(result->err, HasSubstr(c.message));
    EXPECT_FALSE(fs::exists(data_root())) << "refused after opening the store";
  }
  absl::StatusOr<CommandResult> no_tls =
      RunCommand({HDRSTEREOD, "--listen", "0.0.0.0:0", "--data-root",
                  data_root().string()});
  ASSERT_TRUE(no_tls.ok());
  EXPECT_EQ(no_tls->exit_code, 2);
  EXPECT_THAT(no_tls->err, HasSubstr("not a loopback address; remote access "
                                     "needs TLS"));
}

TEST_F(RemoteTest, ApiKeys) {
  StartTlsDaemon({}, /*local_port=*/true);
  CommandResult created =
      As("carol", {"admin", "key", "create", "--user", "bob", "--role",
                   "operator", "--expires", "30d", "--note", "notebook"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  const std::string key(absl::StripAsciiWhitespace(created.out));
  ASSERT_EQ(key.size(), 80u) << key;
  const std::string id = key.substr(3, 12);
  const std::string secret = key.substr(16);
  EXPECT_THAT(created.err, HasSubstr("shown only now"));
  // Above the owner's role, for a user without a role, by a non-admin.
  CommandResult above = As("carol", {"admin", "key", "create", "--user",
                                     "alice", "--role", "operator"});
  EXPECT_EQ(above.exit_code, 2);
  EXPECT_THAT(above.err, HasSubstr("alice is viewer; a key for alice can be at "
                                   "most viewer, not operator"));
  CommandResult roleless = As("carol", {"admin", "key", "create", "--user",
                                        "dave", "--role", "viewer"});
  EXPECT_EQ(roleless.exit_code, 2);
  EXPECT_THAT(roleless.err, HasSubstr("dave has no role in [auth.users]"));
  EXPECT_EQ(
      As("bob", {"admin", "key", "create", "--user", "bob", "--role", "viewer"})
          .exit_code,
      6);
  EXPECT_EQ(Sql("SELECT count(*) FROM api_keys"), "1");

  // The key, over TLS, names bob.
  const std::string file = KeyFile("bob.key", key);
  const std::vector<std::string> with_key = {"--tls-ca", certs_.ca().string(),
                                             "--api-key-file", file};
  auto keyed = [&](std::vector<std::string> args) {
    args.insert(args.begin(), with_key.begin(), with_key.end());
    return Cli(args);
  };
  CommandResult whoami = keyed({"whoami"});
  ASSERT_EQ(whoami.exit_code, 0) << whoami.err;
  EXPECT_THAT(whoami.out, HasSubstr("principal    bob"));
  EXPECT_THAT(whoami.out, HasSubstr("auth         key:" + id));
  EXPECT_THAT(whoami.out, HasSubstr("key expires"));
  ASSERT_EQ(keyed({"session", "create", "k"}).exit_code, 0);
  EXPECT_THAT(
      Audit({"--method", "Sessions/Create"}).back().value("auth_method", ""),
      "key:" + id);
  // A key file others can read is refused before anything is sent.
  const std::string open = KeyFile("open.key", key, 0644);
  CommandResult readable =
      Cli({"--tls-ca", certs_.ca().string(), "--api-key-file", open, "whoami"});
  EXPECT_EQ(readable.exit_code, 2);
  EXPECT_THAT(readable.err, HasSubstr("chmod 600 " + open));
  // Wrong secret, malformed, expired.
  std::string wrong = key;
  wrong.back() = wrong.back() == 'a' ? 'b' : 'a';
  CommandResult bad = Cli({"--tls-ca", certs_.ca().string(), "--api-key-file",
                           KeyFile("wrong.key", wrong), "whoami"});
  EXPECT_EQ(bad.exit_code, 5);
  EXPECT_THAT(bad.err, HasSubstr("API key " + id +
                                 " is unknown or its secret is wrong"));
  CommandResult malformed =
      Cli({"--tls-ca", certs_.ca().string(), "--api-key-file",
           KeyFile("short.key", "hs_0123"), "whoami"});
  EXPECT_EQ(malformed.exit_code, 5);
  EXPECT_THAT(malformed.err, HasSubstr("holds no API key"));
  CommandResult brief = As("carol", {"admin", "key", "create", "--user", "bob",
                                     "--role", "viewer", "--expires", "1s"});
  ASSERT_EQ(brief.exit_code, 0);
  absl::SleepFor(absl::Milliseconds(1500));
  CommandResult expired = Cli(
      {"--tls-ca", certs_.ca().string(), "--api-key-file",
       KeyFile("brief.key", std::string(absl::StripAsciiWhitespace(brief.out))),
       "whoami"});
  EXPECT_EQ(expired.exit_code, 5);
  EXPECT_THAT(expired.err, HasSubstr("expired at"));

  // Revoked while a channel is open: its next call fails.
  auto channel = TlsChannel("", key);
  v1::ServerInfo info;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(
        v1::Server::NewStub(channel)->GetInfo(&context, {}, &info).ok());
  }
  ASSERT_EQ(As("carol", {"admin", "key", "revoke", id}).exit_code, 0);
  {
    grpc::ClientContext context;
    grpc::Status after =
        v1::Server::NewStub(channel)->GetInfo(&context, {}, &info);
    EXPECT_EQ(after.error_code(), grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_THAT(after.error_message(), HasSubstr("was revoked"));
  }
  nlohmann::json keys = AsJson("carol", {"admin", "key", "list", "--all"});
  ASSERT_EQ(keys["keys"].size(), 2u);
  EXPECT_EQ(keys["keys"][0].value("id", ""), id);
  EXPECT_NE(keys["keys"][0].value("revoke_time", ""), "");

  // A key on a plaintext channel is refused, and the daemon warns.
  std::shared_ptr<grpc::Channel> plain =
      grpc::CreateChannel(local_address(), grpc::InsecureChannelCredentials());
  const std::string bearer = "Bearer " + key;
  grpc::Status cleartext = Call(plain, "/hdrstereo.v1.Server/GetInfo", &bearer);
  EXPECT_EQ(cleartext.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(cleartext.error_message(), HasSubstr("accepted over TLS only"));
  EXPECT_THAT(daemon_log(),
              HasSubstr("refused an API key (id " + id + ") sent without TLS"));
  // The secret is in no log, no database row and no listing.
  ASSERT_EQ(StopDaemon(), 0);
  for (const fs::path& path :
       {dir_ / "daemon.log", data_root() / "logs" / "hdrstereod.log",
        data_root() / "hdrstereo.db"}) {
    const std::string text = ReadFileOrDie(path);
    EXPECT_THAT(text, Not(HasSubstr(secret))) << path;
    EXPECT_THAT(text, Not(HasSubstr(secret.substr(0, 20)))) << path;
  }
  EXPECT_THAT(keys.dump(), Not(HasSubstr(secret)));
}

TEST_F(RemoteTest, TheRigLock) {
  StartTlsDaemon({"--scheduler-clock-rate", "60"});
  ASSERT_EQ(As("bob", {"session", "create", "s"}).exit_code, 0);
  CommandResult locked = As("bob", {"hw", "lock", "--ttl", "1h", "--note",
                                    "re-aligning the projector"});
  ASSERT_EQ(locked.exit_code, 0) << locked.err;
  EXPECT_THAT(locked.out, HasSubstr("rig locked by bob until "));
  const std::string until = absl::FormatTime(
      "%H:%M", absl::Now() + absl::Hours(1), absl::LocalTimeZone());
  const std::string reason =
      "locked by bob until " + until + ": re-aligning the projector";

  // Others (also an admin) are refused moves and captures; reads go on.
  for (const char* user : {"erin", "carol"}) {
    CommandResult move = As(user, {"hw", "stage", "move", "10"});
    EXPECT_EQ(move.exit_code, 1) << user;
    EXPECT_THAT(move.err, HasSubstr(reason)) << user;
    CommandResult capture = As(user, {"capture", "stereo", "s"});
    EXPECT_EQ(capture.exit_code, 1) << user;
    EXPECT_THAT(capture.err, HasSubstr(reason)) << user;
  }
  CommandResult status = As("alice", {"hw", "status"});
  EXPECT_EQ(status.exit_code, 0) << status.err;
  EXPECT_THAT(status.out, HasSubstr("lock       locked by bob until "));
  EXPECT_THAT(status.out, HasSubstr(": re-aligning the projector"));
  EXPECT_EQ(As("bob", {"hw", "stage", "move", "10"}).exit_code, 0);
  CommandResult not_yours = As("erin", {"hw", "unlock"});
  EXPECT_EQ(not_yours.exit_code, 1);
  EXPECT_THAT(not_yours.err, HasSubstr("only bob can unlock it"));
  CommandResult not_admin = As("erin", {"hw", "unlock", "--force"});
  EXPECT_EQ(not_admin.exit_code, 6);
  EXPECT_THAT(not_admin.err, HasSubstr("force-unlocking needs role admin"));
  // Bad ttls change nothing.
  CommandResult long_ttl = As("bob", {"hw", "lock", "--ttl", "8d"});
  EXPECT_EQ(long_ttl.exit_code, 2);
  EXPECT_THAT(long_ttl.err, HasSubstr("1 s to 7 days"));
  for (int64_t ttl : {0, -5}) {
    v1::LockRequest request;
    request.set_ttl_s(ttl);
    v1::RigLock response;
    grpc::ClientContext context;
    grpc::Status s = v1::Hardware::NewStub(TlsChannel("bob"))
                         ->Lock(&context, request, &response);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << ttl;
  }
  EXPECT_EQ(Sql("SELECT note FROM rig_lock"), "re-aligning the projector");

  // A schedule that comes due is skipped with the lock's reason.
  ASSERT_EQ(As("carol", {"schedule", "add", "every", "--cron", "* * * * *",
                         "--plan", PlanFile()})
                .exit_code,
            0);
  std::string skipped;
  for (int i = 0; i < 300 && skipped.empty(); ++i) {
    nlohmann::json runs = AsJson("alice", {"schedule", "runs", "every"});
    for (const nlohmann::json& run :
         runs.value("runs", nlohmann::json::array())) {
      if (run.value("outcome", "") == "OUTCOME_SKIPPED")
        skipped = run["reason"];
    }
    if (skipped.empty()) absl::SleepFor(absl::Milliseconds(200));
  }
  EXPECT_EQ(skipped, reason);
  ASSERT_EQ(As("carol", {"schedule", "disable", "every"}).exit_code, 0);
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs"), "0");

  // A restart keeps the lock.
  ASSERT_EQ(StopDaemon(), 0);
  StartTlsDaemon();
  EXPECT_THAT(As("alice", {"hw", "status"}).out,
              HasSubstr(": re-aligning the projector"));
  EXPECT_EQ(As("erin", {"hw", "stage", "move", "5"}).exit_code, 1);
  // An admin force-unlocks; then everyone may move again.
  CommandResult forced = As("carol", {"hw", "unlock", "--force"});
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_THAT(forced.out, HasSubstr("rig free"));
  EXPECT_EQ(As("erin", {"hw", "stage", "move", "5"}).exit_code, 0);
  const std::vector<nlohmann::json> audit = Audit();
  EXPECT_TRUE(Has(audit, "bob", "/hdrstereo.v1.Hardware/Lock", kOk));
  EXPECT_TRUE(Has(audit, "erin", "/hdrstereo.v1.Hardware/MoveStage",
                  kFailedPrecondition));
  EXPECT_TRUE(
      Has(audit, "erin", "/hdrstereo.v1.Hardware/Unlock", kPermissionDenied));
  bool force_audited = false;
  for (const nlohmann::json& e : audit) {
    force_audited |= e.value("principal", "") == "carol" &&
                     e.value("method", "") == "/hdrstereo.v1.Hardware/Unlock" &&
                     e.value("subject", "") == "force" &&
                     e.value("status_code", -1) == kOk;
  }
  EXPECT_TRUE(force_audited);

  // A lock expires at its ttl.
  ASSERT_EQ(As("bob", {"hw", "lock", "--ttl", "1s"}).exit_code, 0);
  EXPECT_EQ(As("erin", {"hw", "stage", "move", "6"}).exit_code, 1);
  absl::SleepFor(absl::Milliseconds(1200));
  EXPECT_EQ(As("erin", {"hw", "stage", "move", "6"}).exit_code, 0);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(RemoteTest, LocalCallersAreLocalWithTheirRole) {
  StartDaemon({"--local-role", "viewer"});
  CommandResult whoami = Cli({"whoami"});
  ASSERT_EQ(whoami.exit_code, 0) << whoami.err;
  EXPECT_THAT(whoami.out, HasSubstr("principal  local"));
  EXPECT_THAT(whoami.out, HasSubstr("role       viewer"));
  EXPECT_EQ(Cli({"session", "list"}).exit_code, 0);
  CommandResult create = Cli({"session", "create", "x"});
  EXPECT_EQ(create.exit_code, 6);
  EXPECT_THAT(create.err, HasSubstr("needs role operator; local has viewer"));
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(RemoteTest, AUnixSocketIsLocalAndOpenToItsGroupOnly) {
  const fs::path socket = dir_ / "hdrstereod.sock";
  StartDaemon({"--listen", "unix:" + socket.string()});
  struct stat st {};
  ASSERT_EQ(::stat(socket.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0660u);
  CommandResult whoami = Cli({"whoami"});
  ASSERT_EQ(whoami.exit_code, 0) << whoami.err;
  EXPECT_THAT(whoami.out, HasSubstr("principal  local"));
  EXPECT_THAT(whoami.out, HasSubstr("role       admin"));
  ASSERT_EQ(Cli({"session", "create", "u"}).exit_code, 0);
  ASSERT_EQ(Cli({"audit"}).exit_code, 0);  // which writes what is queued
  EXPECT_EQ(Sql("SELECT principal || ' ' || auth_method FROM audit WHERE "
                "method = '/hdrstereo.v1.Sessions/Create'"),
            "local local");
  EXPECT_EQ(StopDaemon(), 0);
}

}  // namespace
}  // namespace hdrstereo
