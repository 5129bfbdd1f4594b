// SPDX-License-Identifier: GPL-3.0-or-later
//
// The guard on the path the HTTP edge takes: the daemon (daemon::Server, in
// this process, simulated rig, temporary data root) called through its
// in-process channel, which runs no AuthMetadataProcessor. Every method of
// every hdrstereo.v1 service is refused without the edge's stamp and with a
// stamp not this boot's, and gives every role the same answer as over gRPC
// (tests/support/role_outcomes.h, the table remote_test.cc checks over
// TLS); the audit rows of stamped calls say "http" and name the stamped
// principal and peer. Also the two downloads the HTTP edge serves ranges
// from: DownloadArtifact with length_bytes and DownloadFrame.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "daemon/rpc/call_guard.h"
#include "daemon/rpc/edge_stamp.h"
#include "daemon/server.h"
#include "daemon/store/artifact_repository.h"
#include "daemon/store/session_repository.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"
#include "hdrstereo/v1/server.grpc.pb.h"
#include "hdrstereo/v1/sessions.grpc.pb.h"
#include "processing/io/atomic_file.h"
#include "processing/io/sha256.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/empty_call.h"
#include "tests/support/proto_methods.h"
#include "tests/support/role_outcomes.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr char kHttpPeer[] = "ipv4:10.0.0.7:51234";

rpc::EdgeCaller As(const std::string& name, rpc::Role role) {
  return {.principal = {.name = name,
                        .role = role,
                        .auth_method = "key:0a1b2c3d4e5f",
                        .key_expire_time = std::nullopt},
          .peer = kHttpPeer};
}

class InProcessGuardTest : public testing::DaemonFixture {
 protected:
  void SetUp() override {
    daemon::Config config;
    config.listen = {"127.0.0.1:0"};
    config.data_root = data_root();
    config.hardware = hardware::HardwareMode::kSim;
    config.sim_scene = WriteScene("lab-lamp", testing::SmallLabLamp()).string();
    config.users = {
        {"alice", "viewer"}, {"bob", "operator"}, {"carol", "admin"}};
    ASSERT_OK_AND_ASSIGN(server_, daemon::Server::Start(config));
    channel_ = server_->InProcessChannel();
    ASSERT_NE(channel_, nullptr);
  }
  void TearDown() override {
    if (server_ != nullptr) server_->Shutdown();
  }

  // A context stamped by this boot's edge as `caller`.
  std::unique_ptr<grpc::ClientContext> Stamped(const rpc::EdgeCaller& caller) {
    auto context = std::make_unique<grpc::ClientContext>();
    context->set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(60)));
    server_->edge_stamp().Apply(caller, *context);
    return context;
  }

  // One call of `method` with an empty request and raw bytes back;
  // `prepare` adds the metadata.
  grpc::Status Call(const std::string& method,
                    const std::function<void(grpc::ClientContext&)>& prepare,
                    absl::Duration deadline = absl::Seconds(20)) {
    return testing::CallWithEmptyRequest(channel_, method, prepare, deadline);
  }

  std::vector<store::AuditRecord> AuditRows(const std::string& method) {
    server_->audit_log().Flush();
    store::AuditFilter filter;
    filter.method = method;
    filter.limit = 10000;
    absl::StatusOr<std::vector<store::AuditRecord>> rows =
        server_->audit_log().repository().List(filter);
    EXPECT_TRUE(rows.ok()) << rows.status();
    return rows.value_or(std::vector<store::AuditRecord>{});
  }

  // A download as alice (viewer): its chunks concatenated in `bytes`, the
  // total size they state in `total`; each chunk's offset and sha256 are
  // checked against the range asked for and `sha256`.
  grpc::Status Download(const v1::DownloadFrameRequest& request,
                        const std::string& sha256, std::string* bytes,
                        int64_t* total) {
    v1::Sessions::Stub stub(channel_);
    std::unique_ptr<grpc::ClientContext> context =
        Stamped(As("alice", rpc::Role::kViewer));
    return ReadChunks(*stub.DownloadFrame(context.get(), request),
                      request.offset_bytes(), sha256, bytes, total);
  }
  grpc::Status Download(const v1::DownloadArtifactRequest& request,
                        const std::string& sha256, std::string* bytes,
                        int64_t* total) {
    v1::Sessions::Stub stub(channel_);
    std::unique_ptr<grpc::ClientContext> context =
        Stamped(As("alice", rpc::Role::kViewer));
    return ReadChunks(*stub.DownloadArtifact(context.get(), request),
                      request.offset_bytes(), sha256, bytes, total);
  }
  static grpc::Status ReadChunks(grpc::ClientReader<v1::ArtifactChunk>& reader,
                                 int64_t offset, const std::string& sha256,
                                 std::string* bytes, int64_t* total) {
    bytes->clear();
    v1::ArtifactChunk chunk;
    while (reader.Read(&chunk)) {
      EXPECT_EQ(chunk.offset_bytes(),
                offset + static_cast<int64_t>(bytes->size()));
      EXPECT_EQ(chunk.sha256(), sha256);
      *total = chunk.total_size_bytes();
      bytes->append(chunk.data());
    }
    return reader.Finish();
  }

  std::unique_ptr<daemon::Server> server_;
  std::shared_ptr<grpc::Channel> channel_;
};

TEST_F(InProcessGuardTest, EveryMethodNeedsThisBootsStamp) {
  ASSERT_OK_AND_ASSIGN(rpc::EdgeStamp forger, rpc::EdgeStamp::Create());
  const std::vector<testing::ProtoMethod> methods = testing::AllProtoMethods();
  ASSERT_GE(methods.size(), 38u);
  for (const testing::ProtoMethod& method : methods) {
    const std::string& name = method.full_name;
    grpc::Status none = Call(name, [](grpc::ClientContext&) {});
    EXPECT_EQ(none.error_code(), grpc::StatusCode::UNAUTHENTICATED) << name;
    EXPECT_THAT(none.error_message(),
                HasSubstr("this one carries no x-hdrstereo-edge-stamp"))
        << name;
    // An admin's stamp, but from another boot's edge.
    grpc::Status forged = Call(name, [&](grpc::ClientContext& context) {
      forger.Apply(As("carol", rpc::Role::kAdmin), context);
    });
    EXPECT_EQ(forged.error_code(), grpc::StatusCode::UNAUTHENTICATED) << name;
    EXPECT_THAT(forged.error_message(),
                HasSubstr("x-hdrstereo-edge-stamp does not vouch for this "
                          "caller"))
        << name;
    // A caller without a stamp, and authorization metadata (an API key's
    // place on the network) count for nothing in-process.
    grpc::Status unstamped = Call(name, [](grpc::ClientContext& context) {
      context.AddMetadata(rpc::kEdgeCallerKey, "Y2Fyb2w.YWRtaW4.Y2VydA.eA.");
      context.AddMetadata("authorization", "Bearer hs_0_0");
    });
    EXPECT_EQ(unstamped.error_code(), grpc::StatusCode::UNAUTHENTICATED)
        << name;
  }
  // The handlers did not run.
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM api_keys"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM rig_lock"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM schedules"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM jobs"), "0");
  // Each refusal is audited once, as an in-process call of no one.
  std::vector<store::AuditRecord> rows = AuditRows("");
  EXPECT_EQ(rows.size(), 3 * methods.size());
  for (const store::AuditRecord& row : rows) {
    EXPECT_EQ(row.transport, "in-process") << row.method;
    EXPECT_EQ(row.principal, "") << row.method;
    EXPECT_EQ(row.status_code,
              static_cast<int>(absl::StatusCode::kUnauthenticated))
        << row.method;
  }
}

TEST_F(InProcessGuardTest, EveryRoleGetsTheAnswerItGetsOverGrpc) {
  const std::vector<std::pair<std::string, rpc::Role>> roles = {
      {"dave", rpc::Role::kNone},
      {"alice", rpc::Role::kViewer},
      {"bob", rpc::Role::kOperator},
      {"carol", rpc::Role::kAdmin}};
  const std::vector<testing::ProtoMethod> methods = testing::AllProtoMethods();
  for (const testing::ProtoMethod& method : methods) {
    // An allowed stream (live view) goes on until its deadline.
    const absl::Duration deadline = method.descriptor->server_streaming()
                                        ? absl::Seconds(3)
                                        : absl::Seconds(20);
    for (const auto& [user, role] : roles) {
      testing::ExpectRoleOutcome(
          method.full_name, user, role,
          Call(
              method.full_name,
              [&, user = user, role = role](grpc::ClientContext& context) {
                server_->edge_stamp().Apply(As(user, role), context);
              },
              deadline));
    }
  }
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM api_keys"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM rig_lock"), "0");
  // The refusals are the HTTP caller's, audited as such.
  std::vector<store::AuditRecord> denied =
      AuditRows("/hdrstereo.v1.Sessions/Delete");
  ASSERT_EQ(denied.size(), 4u);  // three refusals, carol's empty name
  EXPECT_EQ(denied[3].principal, "dave");
  EXPECT_EQ(denied[3].transport, "http");
  EXPECT_EQ(denied[3].peer, kHttpPeer);
  EXPECT_EQ(denied[3].status_code,
            static_cast<int>(absl::StatusCode::kPermissionDenied));
}

TEST_F(InProcessGuardTest, StampedCallsAreAuditedAsHttpWithTheirPeer) {
  v1::Sessions::Stub sessions(channel_);
  v1::CreateSessionRequest create;
  create.set_name("via-http");
  v1::Session session;
  grpc::Status created = sessions.Create(
      Stamped(As("bob", rpc::Role::kOperator)).get(), create, &session);
  ASSERT_TRUE(created.ok()) << created.error_message();
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions WHERE name = 'via-http'"), "1");

  std::vector<store::AuditRecord> rows =
      AuditRows("/hdrstereo.v1.Sessions/Create");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].principal, "bob");
  EXPECT_EQ(rows[0].role, "operator");
  EXPECT_EQ(rows[0].auth_method, "key:0a1b2c3d4e5f");
  EXPECT_EQ(rows[0].transport, "http");
  EXPECT_EQ(rows[0].peer, kHttpPeer);
  EXPECT_EQ(rows[0].subject, "session via-http");
  EXPECT_EQ(rows[0].status_code, 0);

  // The handlers see the stamped caller: WhoAmI names it and its address.
  v1::Server::Stub server(channel_);
  v1::Identity identity;
  grpc::Status whoami = server.WhoAmI(
      Stamped(As("bob", rpc::Role::kOperator)).get(), {}, &identity);
  ASSERT_TRUE(whoami.ok()) << whoami.error_message();
  EXPECT_EQ(identity.principal(), "bob");
  EXPECT_EQ(identity.role(), v1::ROLE_OPERATOR);
  EXPECT_EQ(identity.auth_method(), "key:0a1b2c3d4e5f");
  EXPECT_EQ(identity.peer(), kHttpPeer);

  // The role is the stamp's: a viewer's stamp may not create.
  v1::Session refused;
  create.set_name("by-viewer");
  grpc::Status denied = sessions.Create(
      Stamped(As("bob", rpc::Role::kViewer)).get(), create, &refused);
  EXPECT_EQ(denied.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_THAT(denied.error_message(),
              HasSubstr("/hdrstereo.v1.Sessions/Create needs role operator; "
                        "bob has viewer"));
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions WHERE name = 'by-viewer'"), "0");
  EXPECT_EQ(AuditRows("/hdrstereo.v1.Sessions/Create").size(), 2u);
}

// The rig lock holds on this path too: held by bob, it keeps carol's
// stamped calls off the rig.
TEST_F(InProcessGuardTest, TheRigLockHoldsForStampedCalls) {
  v1::Hardware::Stub hardware(channel_);
  v1::LockRequest lock;
  lock.set_note("focusing");
  lock.set_ttl_s(600);
  v1::RigLock held;
  grpc::Status locked = hardware.Lock(
      Stamped(As("bob", rpc::Role::kOperator)).get(), lock, &held);
  ASSERT_TRUE(locked.ok()) << locked.error_message();
  EXPECT_EQ(Sql("SELECT holder FROM rig_lock"), "bob");
  v1::MoveStageRequest move;
  move.set_position_mm(10);
  v1::StageStatus stage;
  grpc::Status moved = hardware.MoveStage(
      Stamped(As("carol", rpc::Role::kAdmin)).get(), move, &stage);
  EXPECT_EQ(moved.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(moved.error_message(), HasSubstr("locked by bob until "));
}

class DownloadTest : public InProcessGuardTest {
 protected:
  // A session with one bracketed-stereo exposure captured in simulation.
  void Capture() {
    v1::Sessions::Stub sessions(channel_);
    v1::CreateSessionRequest create;
    create.set_name("dl");
    v1::Session session;
    ASSERT_TRUE(sessions
                    .Create(Stamped(As("bob", rpc::Role::kOperator)).get(),
                            create, &session)
                    .ok());
    v1::Jobs::Stub jobs(channel_);
    v1::SubmitCaptureRequest submit;
    submit.set_session("dl");
    v1::BracketedStereoPlan* plan =
        submit.mutable_plan()->mutable_bracketed_stereo();
    plan->add_exposures_s(0.01);
    plan->set_baseline_mm(100);
    plan->set_skip_ambient(true);
    v1::Job job;
    grpc::Status submitted = jobs.SubmitCapture(
        Stamped(As("bob", rpc::Role::kOperator)).get(), submit, &job);
    ASSERT_TRUE(submitted.ok()) << submitted.error_message();
    v1::GetJobRequest get;
    get.set_job_id(job.id());
    const absl::Time give_up = absl::Now() + absl::Seconds(120);
    while (job.state() != v1::JOB_STATE_SUCCEEDED && absl::Now() < give_up) {
      ASSERT_NE(job.state(), v1::JOB_STATE_FAILED) << job.DebugString();
      absl::SleepFor(absl::Milliseconds(50));
      ASSERT_TRUE(
          jobs.Get(Stamped(As("bob", rpc::Role::kOperator)).get(), get, &job)
              .ok());
    }
    ASSERT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED) << job.DebugString();
    job_id_ = job.id();
    v1::ListFramesRequest list;
    list.set_session("dl");
    v1::ListFramesResponse frames;
    ASSERT_TRUE(sessions
                    .ListFrames(Stamped(As("alice", rpc::Role::kViewer)).get(),
                                list, &frames)
                    .ok());
    ASSERT_GE(frames.frames_size(), 2);
    frame_ = frames.frames(0);
  }

  int64_t job_id_ = 0;
  v1::Frame frame_;
};

TEST_F(DownloadTest, AFrameWholeAndInRanges) {
  ASSERT_NO_FATAL_FAILURE(Capture());
  const fs::path file = data_root() / "sessions" / "dl" / frame_.path();
  const std::string on_disk = testing::ReadFileOrDie(file);
  ASSERT_GT(on_disk.size(), 100u);
  EXPECT_EQ(io::Sha256Hex(on_disk), frame_.sha256());
  const int64_t size = static_cast<int64_t>(on_disk.size());

  v1::DownloadFrameRequest request;
  request.set_session("dl");
  request.set_frame_id(frame_.id());
  std::string bytes;
  int64_t total = 0;
  grpc::Status whole = Download(request, frame_.sha256(), &bytes, &total);
  ASSERT_TRUE(whole.ok()) << whole.error_message();
  EXPECT_EQ(bytes, on_disk);
  EXPECT_EQ(total, size);

  request.set_offset_bytes(10);
  request.set_length_bytes(20);
  grpc::Status range = Download(request, frame_.sha256(), &bytes, &total);
  ASSERT_TRUE(range.ok()) << range.error_message();
  EXPECT_EQ(bytes, on_disk.substr(10, 20));
  EXPECT_EQ(total, size);

  // To the end from an offset; an empty range at the end.
  request.set_offset_bytes(size - 5);
  request.set_length_bytes(0);
  ASSERT_TRUE(Download(request, frame_.sha256(), &bytes, &total).ok());
  EXPECT_EQ(bytes, on_disk.substr(size - 5));
  request.set_offset_bytes(size);
  ASSERT_TRUE(Download(request, frame_.sha256(), &bytes, &total).ok());
  EXPECT_EQ(bytes, "");
  EXPECT_EQ(total, size);

  request.set_offset_bytes(10);
  request.set_length_bytes(size - 9);
  grpc::Status beyond = Download(request, frame_.sha256(), &bytes, &total);
  EXPECT_EQ(beyond.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_THAT(beyond.error_message(),
              HasSubstr(absl::StrCat("offset_bytes 10 + length_bytes ",
                                     size - 9, " is beyond the end of ",
                                     frame_.path(), " (", size, " bytes)")));
  request.set_offset_bytes(size + 1);
  request.set_length_bytes(0);
  grpc::Status past = Download(request, frame_.sha256(), &bytes, &total);
  EXPECT_EQ(past.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_THAT(past.error_message(),
              HasSubstr(absl::StrCat("offset_bytes ", size + 1,
                                     " is beyond the end of ")));
  request.set_offset_bytes(0);
  request.set_length_bytes(-1);
  grpc::Status negative = Download(request, frame_.sha256(), &bytes, &total);
  EXPECT_EQ(negative.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(negative.error_message(),
              HasSubstr("length_bytes must not be negative"));

  // Only the session's own frames, by id.
  request.set_length_bytes(0);
  request.set_frame_id(frame_.id() + 1000);
  grpc::Status unknown = Download(request, frame_.sha256(), &bytes, &total);
  EXPECT_EQ(unknown.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(
      unknown.error_message(),
      HasSubstr(absl::StrCat("session dl has no frame ", frame_.id() + 1000)));
  ASSERT_OK(
      store::SessionRepository(server_->store()).Create("other", "").status());
  request.set_session("other");
  request.set_frame_id(frame_.id());
  EXPECT_EQ(Download(request, frame_.sha256(), &bytes, &total).error_code(),
            grpc::StatusCode::NOT_FOUND);

  // A frame whose file is gone.
  request.set_session("dl");
  fs::remove(file);
  grpc::Status gone = Download(request, frame_.sha256(), &bytes, &total);
  EXPECT_EQ(gone.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(gone.error_message(),
              HasSubstr(absl::StrCat(frame_.path(), " is missing on disk")));
}

TEST_F(DownloadTest, AnArtifactInRanges) {
  ASSERT_NO_FATAL_FAILURE(Capture());
  const std::string content = "0123456789abcdef";
  const fs::path dir = data_root() / "sessions" / "dl" / "hdr";
  fs::create_directories(dir);
  ASSERT_OK(io::WriteFileAtomically(dir / "test.bin", content));
  ASSERT_OK(io::WriteFileAtomically(dir / "short.bin", content));
  ASSERT_OK_AND_ASSIGN(store::SessionRecord session,
                       store::SessionRepository(server_->store()).Get("dl"));
  const std::string sha = io::Sha256Hex(content);
  store::ArtifactRecord whole;
  whole.step = "hdr";
  whole.kind = "hdr";
  whole.path = "hdr/test.bin";
  whole.sha256 = sha;
  whole.size_bytes = 16;
  store::ArtifactRecord short_one = whole;
  short_one.path = "hdr/short.bin";
  short_one.size_bytes = 17;  // one more than on disk
  ASSERT_OK(store::ArtifactRepository(server_->store())
                .ReplaceStep(session.id, job_id_, "hdr", {whole, short_one}));
  ASSERT_OK_AND_ASSIGN(
      std::vector<store::ArtifactRecord> artifacts,
      store::ArtifactRepository(server_->store()).List("dl", "", 0, 10));
  ASSERT_EQ(artifacts.size(), 2u);

  v1::DownloadArtifactRequest request;
  request.set_session("dl");
  request.set_artifact_id(artifacts[0].id);
  request.set_offset_bytes(4);
  request.set_length_bytes(6);
  std::string bytes;
  int64_t total = 0;
  grpc::Status range = Download(request, sha, &bytes, &total);
  ASSERT_TRUE(range.ok()) << range.error_message();
  EXPECT_EQ(bytes, "456789");
  EXPECT_EQ(total, 16);
  request.set_length_bytes(0);
  ASSERT_TRUE(Download(request, sha, &bytes, &total).ok());
  EXPECT_EQ(bytes, "456789abcdef");

  request.set_offset_bytes(10);
  request.set_length_bytes(7);
  grpc::Status beyond = Download(request, sha, &bytes, &total);
  EXPECT_EQ(beyond.error_code(), grpc::StatusCode::OUT_OF_RANGE);
  EXPECT_THAT(beyond.error_message(),
              HasSubstr("offset_bytes 10 + length_bytes 7 is beyond the end "
                        "of hdr/test.bin (16 bytes)"));
  request.set_length_bytes(-5);
  grpc::Status negative = Download(request, sha, &bytes, &total);
  EXPECT_EQ(negative.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(negative.error_message(),
              HasSubstr("length_bytes must not be negative"));

  // A file whose size is not the recorded one.
  request.set_artifact_id(artifacts[1].id);
  request.set_offset_bytes(0);
  request.set_length_bytes(0);
  grpc::Status damaged = Download(request, sha, &bytes, &total);
  EXPECT_EQ(damaged.error_code(), grpc::StatusCode::DATA_LOSS);
  EXPECT_THAT(damaged.error_message(),
              HasSubstr("hdr/short.bin has 16 bytes on disk but 17 were "
                        "recorded"));
}

}  // namespace
}  // namespace hdrstereo
