// SPDX-License-Identifier: GPL-3.0-or-later
//
// The HTTP edge of the real daemon through libcurl: browser sign-in and
// its cookie, CSRF and Host checks, security headers, Connect errors for
// bad input, server streams (Connect and SSE), live view as binary JPEG,
// downloads with Range and ETag, a session's report as a page with its
// images, the audit of HTTP calls, and loopback without credentials.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "hdrstereo/v1/hardware.pb.h"
#include "processing/io/sha256.h"
#include "tests/integration/http_fixture.h"
#include "tests/support/proto_methods.h"
#include "tests/support/role_outcomes.h"

namespace hdrstereo::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

class HttpTest : public HttpFixture {
 protected:
  // Live view as the binary Connect stream, as bob (it moves nothing but
  // watches the rig: operator).
  HttpRequest LiveView(const v1::StreamPreviewRequest& request) {
    HttpRequest live = To("/hdrstereo.v1.Hardware/StreamPreview", "bob");
    live.headers = {"Content-Type: application/connect+proto"};
    live.body = EnvelopeOf(request.SerializeAsString());
    live.timeout = absl::Seconds(60);
    return live;
  }
};

// The cookie a sign-in response sets, "name=value".
std::string CookieOf(const HttpResponse& response) {
  const std::string set_cookie = response.Header("set-cookie");
  return set_cookie.substr(0, set_cookie.find(';'));
}

// The gRPC code of a Connect error code name, from the Connect protocol's
// documentation (written out here, not taken from the daemon).
grpc::StatusCode CodeOfConnectName(const std::string& name) {
  static const auto* const kCodes = new std::map<std::string, grpc::StatusCode>{
      {"canceled", grpc::StatusCode::CANCELLED},
      {"unknown", grpc::StatusCode::UNKNOWN},
      {"invalid_argument", grpc::StatusCode::INVALID_ARGUMENT},
      {"deadline_exceeded", grpc::StatusCode::DEADLINE_EXCEEDED},
      {"not_found", grpc::StatusCode::NOT_FOUND},
      {"already_exists", grpc::StatusCode::ALREADY_EXISTS},
      {"permission_denied", grpc::StatusCode::PERMISSION_DENIED},
      {"resource_exhausted", grpc::StatusCode::RESOURCE_EXHAUSTED},
      {"failed_precondition", grpc::StatusCode::FAILED_PRECONDITION},
      {"aborted", grpc::StatusCode::ABORTED},
      {"out_of_range", grpc::StatusCode::OUT_OF_RANGE},
      {"unimplemented", grpc::StatusCode::UNIMPLEMENTED},
      {"internal", grpc::StatusCode::INTERNAL},
      {"unavailable", grpc::StatusCode::UNAVAILABLE},
      {"data_loss", grpc::StatusCode::DATA_LOSS},
      {"unauthenticated", grpc::StatusCode::UNAUTHENTICATED}};
  auto it = kCodes->find(name);
  return it == kCodes->end() ? grpc::StatusCode::UNKNOWN : it->second;
}

grpc::Status StatusOfError(const nlohmann::json& error) {
  if (!error.is_object()) return grpc::Status::OK;
  return grpc::Status(CodeOfConnectName(error.value("code", "")),
                      error.value("message", ""));
}

// Every method of every hdrstereo.v1 service, called with an empty request
// over gRPC and then over HTTP, as no one, a principal without a role, and
// each role (client certificates on both): the same refusals, word for
// word, and the same admissions.
TEST_F(HttpTest, EveryMethodAnswersOverHttpAsOverGrpcForEveryRole) {
  StartHttpDaemon();
  const std::vector<std::pair<std::string, rpc::Role>> callers = {
      {"", rpc::Role::kNone},
      {"dave", rpc::Role::kNone},
      {"alice", rpc::Role::kViewer},
      {"bob", rpc::Role::kOperator},
      {"carol", rpc::Role::kAdmin}};
  std::map<std::string, std::shared_ptr<grpc::Channel>> channels;
  for (const auto& [user, role] : callers) channels[user] = TlsChannel(user);
  const std::vector<ProtoMethod> methods = AllProtoMethods();
  ASSERT_GE(methods.size(), 46u);
  for (const ProtoMethod& method : methods) {
    const std::string& name = method.full_name;
    const bool streaming = method.descriptor->server_streaming();
    for (const auto& [user, role] : callers) {
      // An admitted stream (live view) goes on until its deadline.
      const grpc::Status over_grpc =
          Call(channels[user], name, nullptr,
               streaming ? absl::Seconds(3) : absl::Seconds(20));
      HttpRequest request = To(name, user);
      grpc::Status over_http;
      if (streaming) {
        request.headers = {"Content-Type: application/connect+json",
                           "Connect-Timeout-Ms: 3000"};
        request.body = EnvelopeOf("{}");
        HttpResponse response = Fetch(request);
        ASSERT_EQ(response.status, 200) << name << " as " << user;
        std::vector<StreamMessage> messages = ParseEnvelopes(response.body);
        ASSERT_FALSE(messages.empty()) << name << " as " << user;
        ASSERT_TRUE(messages.back().end) << name << " as " << user;
        over_http = StatusOfError(nlohmann::json::parse(messages.back().payload)
                                      .value("error", nlohmann::json()));
      } else {
        request.headers = {"Content-Type: application/json"};
        request.body = "{}";
        HttpResponse response = Fetch(request);
        over_http = response.status == 200 ? grpc::Status::OK
                                           : StatusOfError(response.Json());
      }
      if (user.empty()) {
        EXPECT_EQ(over_grpc.error_code(), grpc::StatusCode::UNAUTHENTICATED)
            << name;
        EXPECT_EQ(over_http.error_code(), grpc::StatusCode::UNAUTHENTICATED)
            << name << ": " << over_http.error_message();
        continue;
      }
      ExpectRoleOutcome(name, user, role, over_grpc);
      ExpectRoleOutcome(name, user, role, over_http);
      if (over_grpc.error_code() == grpc::StatusCode::PERMISSION_DENIED) {
        EXPECT_EQ(over_http.error_message(), over_grpc.error_message())
            << name << " as " << user;
      }
    }
  }
  // The refused calls changed nothing.
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  EXPECT_EQ(Sql("SELECT count(*) FROM api_keys"), "0");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpTest, SignInSetsAStrictSessionCookieThatRevokingTheKeyEnds) {
  StartHttpDaemon();
  const std::string key = CreateKey("bob", "operator");
  ASSERT_EQ(key.size(), 80u);
  const std::string origin = "Origin: " + base_;

  HttpRequest sign_in = To("/auth/sign-in");
  sign_in.headers = {"Content-Type: application/json", origin};
  sign_in.body = absl::StrCat(R"({"apiKey": ")", key, R"("})");
  HttpResponse signed_in = Fetch(sign_in);
  ASSERT_EQ(signed_in.status, 200) << signed_in.body;
  EXPECT_EQ(signed_in.Json().value("user", ""), "bob");
  EXPECT_EQ(signed_in.Json().value("role", ""), "operator");
  const std::string set_cookie = signed_in.Header("set-cookie");
  EXPECT_THAT(set_cookie, HasSubstr("__Host-hdrstereo_session="));
  EXPECT_THAT(set_cookie, HasSubstr("HttpOnly"));
  EXPECT_THAT(set_cookie, HasSubstr("SameSite=Strict"));
  EXPECT_THAT(set_cookie, HasSubstr("Secure"));
  EXPECT_THAT(set_cookie, HasSubstr("Path=/"));
  // The key is never sent back.
  EXPECT_THAT(signed_in.body, Not(HasSubstr(key.substr(16))));
  const std::string cookie = "Cookie: " + CookieOf(signed_in);
  // The console asks whether it is signed in before its first call.
  auto signed_in_state = [&](std::vector<std::string> headers) {
    HttpRequest session = To("/auth/session");
    session.method = "GET";
    session.headers = std::move(headers);
    HttpResponse answer = Fetch(session);
    EXPECT_EQ(answer.status, 200) << answer.body;
    return answer.body;
  };
  EXPECT_EQ(signed_in_state({cookie, origin}), R"({"signedIn":true})");
  EXPECT_EQ(signed_in_state({}), R"({"signedIn":false})");
  // A key is not checked here (key guesses go where they are throttled and
  // audited), good or bad.
  EXPECT_EQ(signed_in_state({"Authorization: Bearer " + key}),
            R"({"signedIn":false})");
  HttpRequest post_session = To("/auth/session");
  post_session.headers = {cookie, origin, "Content-Type: application/json"};
  post_session.body = "{}";
  EXPECT_EQ(Fetch(post_session).status, 405);

  HttpResponse whoami = Unary("Server/WhoAmI", "{}", "", {cookie, origin});
  ASSERT_EQ(whoami.status, 200) << whoami.body;
  EXPECT_EQ(whoami.Json().value("principal", ""), "bob") << whoami.body;
  // With the cookie, a request must show where it comes from.
  HttpResponse no_origin = Unary("Server/WhoAmI", "{}", "", {cookie});
  EXPECT_EQ(no_origin.status, 403);
  EXPECT_EQ(no_origin.Json().value("code", ""), "permission_denied");
  EXPECT_THAT(no_origin.Json().value("message", ""),
              HasSubstr("must carry the Origin header"));

  // Revoking the key ends the session at once.
  const std::string id = key.substr(3, 12);
  ASSERT_EQ(As("carol", {"admin", "key", "revoke", id}).exit_code, 0);
  HttpResponse revoked = Unary("Server/WhoAmI", "{}", "", {cookie, origin});
  EXPECT_EQ(revoked.status, 401);
  EXPECT_EQ(revoked.Json().value("code", ""), "unauthenticated");
  EXPECT_THAT(revoked.Json().value("message", ""),
              HasSubstr("API key " + id + " was revoked"));
  EXPECT_EQ(signed_in_state({cookie, origin}), R"({"signedIn":false})");

  // Sign-out ends a session and clears the cookie.
  const std::string other = CreateKey("alice", "viewer");
  sign_in.body = absl::StrCat(R"({"apiKey": ")", other, R"("})");
  HttpResponse second = Fetch(sign_in);
  ASSERT_EQ(second.status, 200) << second.body;
  const std::string second_cookie = "Cookie: " + CookieOf(second);
  HttpRequest sign_out = To("/auth/sign-out");
  sign_out.headers = {second_cookie, origin};
  HttpResponse out = Fetch(sign_out);
  EXPECT_EQ(out.status, 200) << out.body;
  EXPECT_THAT(out.Header("set-cookie"), HasSubstr("Max-Age=0"));
  HttpResponse after =
      Unary("Server/WhoAmI", "{}", "", {second_cookie, origin});
  EXPECT_EQ(after.status, 401);
  EXPECT_THAT(after.Json().value("message", ""),
              HasSubstr("the browser session has ended"));
  // Bearer keys work without a session (curl, MATLAB).
  const std::string third = CreateKey("alice", "viewer");
  HttpResponse bearer =
      Unary("Server/WhoAmI", "{}", "", {"Authorization: Bearer " + third});
  ASSERT_EQ(bearer.status, 200) << bearer.body;
  EXPECT_EQ(bearer.Json().value("principal", ""), "alice");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpTest, FailedSignInsAreAuditedAndLimitedPerAddress) {
  StartHttpDaemon();
  const std::string key = CreateKey("bob", "operator");
  std::string wrong = key;
  wrong.back() = wrong.back() == 'a' ? 'b' : 'a';
  HttpRequest sign_in = To("/auth/sign-in");
  sign_in.headers = {"Content-Type: application/json"};
  // Something that is no key at all is said so, and is not a guess.
  sign_in.body = R"({"apiKey": "my password"})";
  HttpResponse malformed = Fetch(sign_in);
  EXPECT_EQ(malformed.status, 400) << malformed.body;
  EXPECT_THAT(malformed.Json().value("message", ""),
              HasSubstr("apiKey: that is not an API key"));
  sign_in.body = absl::StrCat(R"({"apiKey": ")", wrong, R"("})");
  for (int i = 0; i < 10; ++i) {
    HttpResponse refused = Fetch(sign_in);
    EXPECT_EQ(refused.status, 401) << refused.body;
    EXPECT_THAT(refused.Json().value("message", ""),
                HasSubstr("is unknown or its secret is wrong"));
    EXPECT_TRUE(refused.Header("set-cookie").empty());
  }
  // The 11th within a minute is refused before the key is looked at, even
  // the right one.
  sign_in.body = absl::StrCat(R"({"apiKey": ")", key, R"("})");
  HttpResponse limited = Fetch(sign_in);
  EXPECT_EQ(limited.status, 429) << limited.body;
  EXPECT_EQ(limited.Json().value("code", ""), "resource_exhausted");
  EXPECT_THAT(limited.Json().value("message", ""),
              HasSubstr("too many failed sign-ins from ipv4:127.0.0.1"));
  // Listing the audit log writes out what is queued.
  ASSERT_EQ(As("carol", {"audit"}).exit_code, 0);
  EXPECT_EQ(Sql("SELECT count(*) FROM audit WHERE method = '\"/auth/sign-in\"' "
                "AND transport = 'http' AND status_code = 16 AND peer LIKE "
                "'ipv4:127.0.0.1:%'"),
            "10");
  EXPECT_EQ(Sql("SELECT count(*) FROM audit WHERE method = '\"/auth/sign-in\"' "
                "AND status_code = 8"),
            "1");
  // Guessing keys in the Authorization header counts the same.
  HttpResponse guess =
      Unary("Server/WhoAmI", "{}", "", {"Authorization: Bearer " + wrong});
  EXPECT_EQ(guess.status, 429);
  EXPECT_THAT(guess.Json().value("message", ""),
              HasSubstr("too many failed sign-ins"));
  // No secret in the audit log or the daemon's log.
  EXPECT_EQ(Sql(absl::StrCat("SELECT count(*) FROM audit WHERE message LIKE '%",
                             key.substr(16), "%'")),
            "0");
  EXPECT_THAT(daemon_log(), Not(HasSubstr(key.substr(16))));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpTest, CrossSiteAndForeignHostRequestsAreRefused) {
  StartHttpDaemon();
  // Every content type an HTML form can send.
  for (const char* type : {"application/x-www-form-urlencoded",
                           "multipart/form-data; boundary=x", "text/plain"}) {
    HttpRequest form = To("/hdrstereo.v1.Sessions/Create", "bob");
    form.headers = {absl::StrCat("Content-Type: ", type)};
    form.body = R"({"name": "form"})";
    HttpResponse refused = Fetch(form);
    EXPECT_EQ(refused.status, 415) << type;
    EXPECT_THAT(refused.Json().value("message", ""),
                HasSubstr("takes Content-Type application/json"));
  }
  // Another page's origin.
  HttpResponse foreign = Unary("Sessions/Create", R"({"name": "csrf"})", "bob",
                               {"Origin: https://evil.example"});
  EXPECT_EQ(foreign.status, 403);
  EXPECT_THAT(foreign.Json().value("message", ""),
              HasSubstr("cross-site requests are refused"));
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  // A preflight finds no CORS permission; GET changes nothing.
  HttpRequest preflight = To("/hdrstereo.v1.Sessions/Create", "bob");
  preflight.method = "OPTIONS";
  preflight.headers = {"Origin: https://evil.example",
                       "Access-Control-Request-Method: POST"};
  HttpResponse options = Fetch(preflight);
  EXPECT_EQ(options.status, 405);
  for (const auto& [name, value] : options.headers) {
    EXPECT_FALSE(absl::StartsWith(name, "access-control-")) << name;
  }
  HttpRequest get = To("/hdrstereo.v1.Sessions/Create", "bob");
  get.method = "GET";
  EXPECT_EQ(Fetch(get).status, 405);
  // DNS rebinding: a name the daemon is not served under.
  HttpRequest rebound = To("/hdrstereo.v1.Server/GetInfo", "bob");
  rebound.headers = {"Host: attacker.example",
                     "Content-Type: application/json"};
  rebound.body = "{}";
  HttpResponse host = Fetch(rebound);
  EXPECT_EQ(host.status, 403);
  EXPECT_THAT(host.Json().value("message", ""),
              HasSubstr("not served under the name \"attacker.example\""));
  // Security headers on every answer, successful or not.
  for (const HttpResponse& response :
       {Unary("Server/GetInfo", "{}", "alice"), foreign, options, host,
        Fetch(To("/nowhere", "alice"))}) {
    EXPECT_THAT(response.Header("content-security-policy"),
                HasSubstr("default-src"));
    EXPECT_EQ(response.Header("x-content-type-options"), "nosniff");
    EXPECT_EQ(response.Header("referrer-policy"), "no-referrer");
  }
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpTest, BadRequestsGetConnectErrorsAndChangeNothing) {
  StartHttpDaemon({"--http-max-body-kb", "1"});
  HttpResponse unknown_field =
      Unary("Sessions/Create", R"({"name": "x", "colour": 3})", "bob");
  EXPECT_EQ(unknown_field.status, 400);
  EXPECT_EQ(unknown_field.Json().value("code", ""), "invalid_argument");
  EXPECT_THAT(unknown_field.Json().value("message", ""), HasSubstr("colour"));
  HttpResponse malformed = Unary("Sessions/Create", R"({"name": )", "bob");
  EXPECT_EQ(malformed.status, 400);
  EXPECT_THAT(malformed.Json().value("message", ""),
              HasSubstr("not a JSON hdrstereo.v1.CreateSessionRequest"));
  HttpResponse wrong_type = Unary("Jobs/Get", R"({"jobId": "seven"})", "bob");
  EXPECT_EQ(wrong_type.status, 400);
  // protobuf names the field as the .proto does.
  EXPECT_THAT(wrong_type.Json().value("message", ""), HasSubstr("job_id"));
  // The service's own validation, its message unchanged.
  HttpResponse invalid = Unary("Sessions/Create", R"({"name": "a/b"})", "bob");
  EXPECT_EQ(invalid.status, 400);
  EXPECT_EQ(invalid.Json().value("code", ""), "invalid_argument");
  HttpResponse missing = Unary("Jobs/Get", R"({"jobId": "77"})", "bob");
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(missing.Json().value("code", ""), "not_found");
  // Routes.
  HttpResponse no_route = Fetch(To("/index.php", "bob"));
  EXPECT_EQ(no_route.status, 404);
  EXPECT_EQ(no_route.Json().value("code", ""), "not_found");
  HttpResponse no_method = Unary("Jobs/Explode", "{}", "bob");
  EXPECT_EQ(no_method.status, 501);
  EXPECT_EQ(no_method.Json().value("code", ""), "unimplemented");
  // Limits.
  HttpResponse big = Unary("Sessions/Create",
                           absl::StrCat(R"({"name": "big", "description": ")",
                                        std::string(2000, 'x'), R"("})"),
                           "bob");
  EXPECT_EQ(big.status, 413);
  EXPECT_THAT(big.Json().value("message", ""),
              HasSubstr("larger than the limit of 1024 bytes"));
  HttpRequest huge_header = To("/hdrstereo.v1.Server/GetInfo", "bob");
  huge_header.headers = {"Content-Type: application/json",
                         "X-Padding: " + std::string(20000, 'p')};
  huge_header.body = "{}";
  EXPECT_EQ(Fetch(huge_header).status, 431);
  HttpResponse timeout =
      Unary("Server/GetInfo", "{}", "bob", {"Connect-Timeout-Ms: soon"});
  EXPECT_EQ(timeout.status, 400);
  EXPECT_THAT(timeout.Json().value("message", ""),
              HasSubstr("Connect-Timeout-Ms must be"));
  EXPECT_EQ(Sql("SELECT count(*) FROM sessions"), "0");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpTest, JobsWatchStreamsOverConnectAndServerSentEvents) {
  StartHttpDaemon();
  const std::string job = SubmitStereoCapture("watched", "[0.01, 0.02]");
  ASSERT_FALSE(job.empty());

  HttpRequest watch = To("/hdrstereo.v1.Jobs/Watch", "alice");
  watch.headers = {"Content-Type: application/connect+json"};
  watch.body = EnvelopeOf(absl::StrCat(R"({"jobId": ")", job, R"("})"));
  watch.timeout = absl::Seconds(120);
  HttpResponse stream = Fetch(watch);
  ASSERT_EQ(stream.status, 200) << stream.curl_error;
  EXPECT_EQ(stream.Header("content-type"), "application/connect+json");
  std::vector<StreamMessage> messages = ParseEnvelopes(stream.body);
  ASSERT_GE(messages.size(), 3u);
  ASSERT_TRUE(messages.back().end);
  EXPECT_EQ(messages.back().payload, "{}");
  int64_t last_sequence = 0;
  for (size_t i = 0; i + 1 < messages.size(); ++i) {
    EXPECT_FALSE(messages[i].end);
    nlohmann::json event = nlohmann::json::parse(messages[i].payload);
    const int64_t sequence = JsonInt(event["sequence"]);
    EXPECT_EQ(sequence, last_sequence + 1) << messages[i].payload;
    last_sequence = sequence;
  }
  EXPECT_EQ(nlohmann::json::parse(messages[messages.size() - 2].payload)
                .value("state", ""),
            "JOB_STATE_SUCCEEDED");

  // The same history as server-sent events, for curl.
  HttpRequest sse = To("/hdrstereo.v1.Jobs/Watch", "alice");
  sse.headers = {"Content-Type: application/json", "Accept: text/event-stream"};
  sse.body = absl::StrCat(R"({"jobId": ")", job, R"("})");
  HttpResponse events = Fetch(sse);
  ASSERT_EQ(events.status, 200);
  EXPECT_EQ(events.Header("content-type"), "text/event-stream");
  std::vector<std::string> blocks =
      absl::StrSplit(events.body, "\n\n", absl::SkipEmpty());
  ASSERT_EQ(blocks.size(), messages.size());
  EXPECT_EQ(blocks.back(), "event: end\ndata: {}");
  EXPECT_EQ(blocks.front(), "data: " + messages.front().payload);
  // A stream's error is its end message (HTTP 200, as Connect says).
  watch.body = EnvelopeOf(R"({"jobId": "999"})");
  std::vector<StreamMessage> missing = ParseEnvelopes(Fetch(watch).body);
  ASSERT_EQ(missing.size(), 1u);
  EXPECT_TRUE(missing[0].end);
  EXPECT_EQ(nlohmann::json::parse(missing[0].payload)["error"]["code"],
            "not_found");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpTest, LiveViewSendsJpegFramesAsBinaryMessages) {
  StartHttpDaemon();
  v1::StreamPreviewRequest request;
  request.set_max_frames(3);
  HttpRequest live = LiveView(request);
  HttpResponse stream = Fetch(live);
  ASSERT_EQ(stream.status, 200) << stream.curl_error;
  EXPECT_EQ(stream.Header("content-type"), "application/connect+proto");
  std::vector<StreamMessage> messages = ParseEnvelopes(stream.body);
  ASSERT_EQ(messages.size(), 5u)  // 3 frames, "ended", end of stream
      << (messages.empty() ? "" : messages.back().payload);
  for (int i = 0; i < 3; ++i) {
    v1::PreviewMessage message;
    ASSERT_TRUE(message.ParseFromString(messages[i].payload));
    ASSERT_TRUE(message.has_frame());
    const std::string& jpeg = message.frame().jpeg();
    ASSERT_GT(jpeg.size(), 100u);
    // The JPEG's own bytes, not base64.
    EXPECT_EQ(static_cast<uint8_t>(jpeg[0]), 0xFF);
    EXPECT_EQ(static_cast<uint8_t>(jpeg[1]), 0xD8);
    EXPECT_GT(message.frame().width_px(), 0);
  }
  v1::PreviewMessage ended;
  ASSERT_TRUE(ended.ParseFromString(messages[3].payload));
  EXPECT_THAT(ended.ended().reason(), HasSubstr("sent the 3 frames"));
  EXPECT_TRUE(messages[4].end);
  EXPECT_EQ(StopDaemon(), 0);
}

// A viewer that takes frames more slowly than the camera makes them gets
// the newest one each time: the frames in between are dropped, not queued.
TEST_F(HttpTest, ASlowViewerGetsTheNewestFrameNotABacklog) {
  StartHttpDaemon();
  v1::StreamPreviewRequest request;
  request.set_max_fps(10);
  HttpRequest live = LiveView(request);
  // A slow link: little buffered in the client's kernel.
  live.receive_buffer_bytes = 4096;
  std::string buffered;
  std::vector<int64_t> sequences;
  live.on_body = [&](const std::string& bytes) {
    buffered += bytes;
    while (std::optional<StreamMessage> envelope = TakeEnvelope(buffered)) {
      v1::PreviewMessage message;
      EXPECT_TRUE(message.ParseFromString(envelope->payload));
      if (!message.has_frame()) return false;
      sequences.push_back(message.frame().sequence());
      // This viewer takes about 3 frames a second of the 10 made.
      absl::SleepFor(absl::Milliseconds(300));
      if (sequences.size() == 20) return false;
    }
    return true;
  };
  Fetch(live);
  ASSERT_EQ(sequences.size(), 20u);
  for (size_t i = 1; i < sequences.size(); ++i) {
    EXPECT_GT(sequences[i], sequences[i - 1]);
  }
  // 20 frames taken over 6 s while 60 were made: what the kernel's socket
  // buffers hold (64 KiB a side, a few small frames) comes late, the rest
  // was dropped; a queue would have given frames 1 to 20.
  EXPECT_GE(sequences.back(), 30) << absl::StrJoin(sequences, " ");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpTest, FramesAndArtifactsDownloadWithRangesAndTheirSha256AsEtag) {
  StartHttpDaemon();
  const std::string job = SubmitStereoCapture("files", "[0.01]");
  ASSERT_FALSE(job.empty());
  ASSERT_EQ(FinalState(job, "alice"), "JOB_STATE_SUCCEEDED");
  HttpResponse frames =
      Unary("Sessions/ListFrames", R"({"session": "files"})", "alice");
  ASSERT_EQ(frames.status, 200) << frames.body;
  const nlohmann::json frame = frames.Json()["frames"][0];
  const std::string sha256 = frame.value("sha256", "");
  const std::string url =
      absl::StrCat("/files/sessions/files/frames/", JsonInt(frame["id"]));
  HttpRequest get = To(url, "alice");
  get.method = "GET";
  HttpResponse whole = Fetch(get);
  ASSERT_EQ(whole.status, 200) << whole.body;
  EXPECT_EQ(io::Sha256Hex(whole.body), sha256);
  EXPECT_EQ(whole.Header("etag"), "\"" + sha256 + "\"");
  EXPECT_EQ(whole.Header("accept-ranges"), "bytes");
  EXPECT_EQ(whole.Header("content-length"), std::to_string(whole.body.size()));
  EXPECT_EQ(whole.Header("content-type"), "image/png");
  EXPECT_THAT(whole.Header("content-security-policy"), HasSubstr("sandbox"));
  // A range, as a resumed download asks for it.
  get.headers = {"Range: bytes=10-19"};
  HttpResponse part = Fetch(get);
  EXPECT_EQ(part.status, 206);
  EXPECT_EQ(part.body, whole.body.substr(10, 10));
  EXPECT_EQ(part.Header("content-range"),
            absl::StrCat("bytes 10-19/", whole.body.size()));
  get.headers = {absl::StrCat("Range: bytes=", whole.body.size() - 5, "-")};
  EXPECT_EQ(Fetch(get).body, whole.body.substr(whole.body.size() - 5));
  // A range reaching past the end is cut to the file.
  get.headers = {"Range: bytes=0-999999999"};
  HttpResponse clipped = Fetch(get);
  EXPECT_EQ(clipped.status, 206);
  EXPECT_EQ(clipped.body, whole.body);
  EXPECT_EQ(
      clipped.Header("content-range"),
      absl::StrCat("bytes 0-", whole.body.size() - 1, "/", whole.body.size()));
  get.headers = {absl::StrCat("Range: bytes=", whole.body.size(), "-")};
  HttpResponse beyond = Fetch(get);
  EXPECT_EQ(beyond.status, 416);
  EXPECT_EQ(beyond.Header("content-range"),
            absl::StrCat("bytes */", whole.body.size()));
  // If-Range with another file's tag: the whole file.
  get.headers = {"Range: bytes=10-19", "If-Range: \"0000\""};
  EXPECT_EQ(Fetch(get).body, whole.body);
  // Unchanged: 304 without a body.
  get.headers = {"If-None-Match: \"" + sha256 + "\""};
  HttpResponse unchanged = Fetch(get);
  EXPECT_EQ(unchanged.status, 304);
  EXPECT_TRUE(unchanged.body.empty());
  EXPECT_TRUE(unchanged.Header("content-length").empty());
  HttpRequest head = To(url, "alice");
  head.method = "HEAD";
  HttpResponse headers = Fetch(head);
  EXPECT_EQ(headers.status, 200);
  EXPECT_EQ(headers.Header("content-length"),
            std::to_string(whole.body.size()));
  // Needs credentials and a role like the RPC.
  HttpRequest anonymous = To(url);
  anonymous.method = "GET";
  EXPECT_EQ(Fetch(anonymous).status, 401);
  HttpRequest roleless = To(url, "dave");
  roleless.method = "GET";
  HttpResponse denied = Fetch(roleless);
  EXPECT_EQ(denied.status, 403);
  EXPECT_THAT(denied.Json().value("message", ""),
              HasSubstr("dave has no role"));
  HttpRequest no_file = To("/files/sessions/files/frames/999999", "alice");
  no_file.method = "GET";
  EXPECT_EQ(Fetch(no_file).status, 404);
  EXPECT_EQ(StopDaemon(), 0);
}

// A processed session's report as a page in the browser: index.html and
// the images beside it by their names under /files/sessions/<s>/report/,
// where the page's relative links resolve; found with ListArtifacts and
// sent by DownloadArtifact as the caller (the id route's guard and audit),
// under a CSP that lets the page have its inline style and its images.
TEST_F(HttpTest, TheReportIsAPageWhoseImagesResolveToTheReportRoute) {
  StartHttpDaemon();
  const std::string capture = SubmitStereoCapture("rep", "[0.01, 0.04]");
  ASSERT_FALSE(capture.empty());
  ASSERT_EQ(FinalState(capture, "alice"), "JOB_STATE_SUCCEEDED");
  HttpResponse submitted =
      Unary("Jobs/SubmitProcessing",
            R"({"session": "rep", "steps": ["report"]})", "bob");
  ASSERT_EQ(submitted.status, 200) << submitted.body;
  ASSERT_EQ(FinalState(submitted.Json().value("id", ""), "alice"),
            "JOB_STATE_SUCCEEDED")
      << daemon_log();
  const std::filesystem::path folder = data_root() / "sessions/rep/report";
  const std::string page = ReadFileOrDie(folder / "index.html");
  const std::string kReportPolicy =
      "sandbox allow-same-origin; default-src 'none'; img-src 'self'; "
      "style-src 'unsafe-inline'; base-uri 'none'; form-action 'none'; "
      "frame-ancestors 'none'";

  // alice is a viewer: reading a session's files is a viewer's right.
  HttpRequest get = To("/files/sessions/rep/report/index.html", "alice");
  get.method = "GET";
  HttpResponse shown = Fetch(get);
  ASSERT_EQ(shown.status, 200) << shown.body;
  EXPECT_EQ(shown.body, page);
  EXPECT_EQ(shown.Header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(shown.Header("content-security-policy"), kReportPolicy);
  EXPECT_EQ(shown.Header("x-content-type-options"), "nosniff");
  EXPECT_EQ(shown.Header("etag"), "\"" + io::Sha256Hex(page) + "\"");
  EXPECT_EQ(shown.Header("accept-ranges"), "bytes");
  // The page shows its images by plain relative names, which a browser
  // resolves against /files/sessions/rep/report/ to this route.
  const std::string image = "error_simulation_fused.png";
  ASSERT_THAT(page, HasSubstr(absl::StrCat("<img src=\"", image, "\"")));
  HttpRequest get_image =
      To(absl::StrCat("/files/sessions/rep/report/", image), "alice");
  get_image.method = "GET";
  HttpResponse picture = Fetch(get_image);
  ASSERT_EQ(picture.status, 200) << picture.body;
  EXPECT_EQ(picture.body, ReadFileOrDie(folder / image));
  EXPECT_EQ(picture.Header("content-type"), "image/png");
  EXPECT_EQ(picture.Header("content-security-policy"), kReportPolicy);
  // Range, If-None-Match and HEAD as on the id route.
  get_image.headers = {"Range: bytes=8-23"};
  HttpResponse part = Fetch(get_image);
  EXPECT_EQ(part.status, 206);
  EXPECT_EQ(part.body, picture.body.substr(8, 16));
  EXPECT_EQ(part.Header("content-range"),
            absl::StrCat("bytes 8-23/", picture.body.size()));
  get.headers = {"If-None-Match: \"" + io::Sha256Hex(page) + "\""};
  HttpResponse unchanged = Fetch(get);
  EXPECT_EQ(unchanged.status, 304);
  EXPECT_TRUE(unchanged.body.empty());
  HttpRequest head = To("/files/sessions/rep/report/index.html", "alice");
  head.method = "HEAD";
  HttpResponse headers = Fetch(head);
  EXPECT_EQ(headers.status, 200);
  EXPECT_EQ(headers.Header("content-length"), std::to_string(page.size()));
  EXPECT_TRUE(headers.body.empty());

  // The same file by its id keeps the id route's answer: a download.
  HttpResponse listed =
      Unary("Sessions/ListArtifacts", R"({"session": "rep", "kind": "report"})",
            "alice");
  ASSERT_EQ(listed.status, 200) << listed.body;
  const nlohmann::json artifacts = listed.Json()["artifacts"];
  std::string index_id;
  for (const nlohmann::json& artifact : artifacts) {
    if (artifact.value("path", "") == "report/index.html") {
      index_id = std::to_string(JsonInt(artifact["id"]));
    }
  }
  ASSERT_FALSE(index_id.empty()) << "no report/index.html artifact";
  HttpRequest by_id =
      To(absl::StrCat("/files/sessions/rep/artifacts/", index_id), "alice");
  by_id.method = "GET";
  HttpResponse downloaded = Fetch(by_id);
  EXPECT_EQ(downloaded.body, page);
  EXPECT_EQ(downloaded.Header("content-type"), "application/octet-stream");
  EXPECT_EQ(downloaded.Header("content-security-policy"),
            "sandbox; default-src 'none'");

  // Names other than one plain name, sent as written, and unknown names.
  const std::string kNameRule =
      "(a report file is named by one plain name of at most 128 letters, "
      "digits, '.', '-' and '_', not starting with '.', as in "
      "/files/sessions/<session>/report/index.html)";
  for (const char* name :
       {"..", "../report/index.html", "a/index.html", "%2e%2e", ".", ""}) {
    HttpRequest odd =
        To(absl::StrCat("/files/sessions/rep/report/", name), "alice");
    odd.method = "GET";
    odd.path_as_is = true;
    HttpResponse refused = Fetch(odd);
    EXPECT_EQ(refused.status, 404) << name;
    EXPECT_EQ(refused.Json().value("message", ""),
              absl::StrCat("no such report file: \"", name, "\" ", kNameRule))
        << name;
  }
  HttpRequest unknown = To("/files/sessions/rep/report/nope.png", "alice");
  unknown.method = "GET";
  HttpResponse missing = Fetch(unknown);
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(missing.Json().value("message", ""),
            "session rep has no report file \"nope.png\" (a processed "
            "session's report is at /files/sessions/rep/report/index.html)");
  HttpRequest elsewhere = To("/files/sessions/none/report/index.html", "alice");
  elsewhere.method = "GET";
  HttpResponse no_session = Fetch(elsewhere);
  EXPECT_EQ(no_session.status, 404);
  EXPECT_EQ(no_session.Json().value("message", ""),
            "no session named \"none\"");

  // Credentials and a role, as for the RPCs.
  HttpRequest anonymous = To("/files/sessions/rep/report/index.html");
  anonymous.method = "GET";
  HttpResponse unauthenticated = Fetch(anonymous);
  EXPECT_EQ(unauthenticated.status, 401);
  EXPECT_THAT(unauthenticated.Json().value("message", ""),
              HasSubstr("no credentials"));
  HttpRequest roleless = To("/files/sessions/rep/report/index.html", "dave");
  roleless.method = "GET";
  HttpResponse denied = Fetch(roleless);
  EXPECT_EQ(denied.status, 403);
  EXPECT_THAT(denied.Json().value("message", ""),
              HasSubstr("dave has no role"));
  // Refusals are audited as on the id route: the guard's (the call it
  // refused, over HTTP) and the edge's for no credentials.
  ASSERT_EQ(As("carol", {"audit"}).exit_code, 0);
  EXPECT_EQ(Sql("SELECT count(*) FROM audit WHERE method = "
                "'/hdrstereo.v1.Sessions/ListArtifacts' AND principal = "
                "'dave' AND transport = 'http' AND status_code = 7"),
            "1");
  EXPECT_EQ(Sql("SELECT count(*) FROM audit WHERE method LIKE "
                "'%/files/sessions/rep/report/index.html%' AND principal = "
                "'' AND transport = 'http' AND status_code = 16"),
            "1");
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpTest, HttpCallsAreAuditedWithTheirPrincipalTransportAndPeer) {
  StartHttpDaemon();
  ASSERT_EQ(Unary("Sessions/Create", R"({"name": "audited"})", "bob").status,
            200);
  EXPECT_EQ(Unary("Sessions/Delete", R"({"name": "audited"})", "alice").status,
            403);
  // Listing the audit log writes out what is queued.
  ASSERT_EQ(As("carol", {"audit"}).exit_code, 0);
  EXPECT_EQ(Sql("SELECT principal || ' ' || transport || ' ' || status_code "
                "FROM audit WHERE method = '/hdrstereo.v1.Sessions/Create'"),
            "bob http 0");
  EXPECT_EQ(Sql("SELECT count(*) FROM audit WHERE method = "
                "'/hdrstereo.v1.Sessions/Create' AND peer LIKE "
                "'ipv4:127.0.0.1:%' AND auth_method = 'cert' AND subject = "
                "'session audited'"),
            "1");
  EXPECT_EQ(Sql("SELECT principal || ' ' || transport || ' ' || status_code "
                "FROM audit WHERE method = '/hdrstereo.v1.Sessions/Delete'"),
            "alice http 7");
  EXPECT_EQ(StopDaemon(), 0);
}

// Client certificates are verified at the TLS handshake as on gRPC: the
// lab CA's, unexpired, not revoked (its CRL).
TEST_F(HttpTest, CertificatesTheLabDoesNotVouchForAreRefusedAtTheHandshake) {
  StartHttpDaemon();
  for (const char* user : {"revoked", "expired", "mallory"}) {
    HttpResponse refused = Unary("Server/WhoAmI", "{}", user);
    EXPECT_EQ(refused.status, 0) << user << ": " << refused.body;
    EXPECT_FALSE(refused.curl_error.empty()) << user;
  }
  HttpResponse erin = Unary("Server/WhoAmI", "{}", "erin");
  ASSERT_EQ(erin.status, 200) << erin.curl_error << erin.body;
  EXPECT_EQ(erin.Json().value("principal", ""), "erin");
  EXPECT_EQ(erin.Json().value("authMethod", ""), "cert") << erin.body;
  EXPECT_EQ(StopDaemon(), 0);
}

// Loopback HTTP without TLS still needs credentials: a page in the
// operator's own browser can reach 127.0.0.1.
TEST_F(HttpTest, LoopbackHttpIsNeverLocal) {
  StartDaemon({"--http-listen", "127.0.0.1:0", "--auth-user", "erin=viewer"});
  ASSERT_FALSE(http_urls_.empty()) << daemon_log();
  EXPECT_TRUE(absl::StartsWith(http_urls_[0], "http://127.0.0.1:"));
  HttpRequest anonymous;
  anonymous.url = http_urls_[0] + "/hdrstereo.v1.Server/WhoAmI";
  anonymous.headers = {"Content-Type: application/json"};
  anonymous.body = "{}";
  HttpResponse refused = Fetch(anonymous);
  EXPECT_EQ(refused.status, 401);
  EXPECT_THAT(refused.Json().value("message", ""),
              HasSubstr("no credentials: sign in"));
  // The local CLI (admin on loopback gRPC) makes a key; HTTP on loopback
  // takes it without TLS.
  CommandResult created =
      Cli({"admin", "key", "create", "--user", "erin", "--role", "viewer"});
  ASSERT_EQ(created.exit_code, 0) << created.err;
  HttpRequest keyed = anonymous;
  keyed.headers.push_back("Authorization: Bearer " +
                          std::string(absl::StripAsciiWhitespace(created.out)));
  HttpResponse whoami = Fetch(keyed);
  ASSERT_EQ(whoami.status, 200) << whoami.body;
  EXPECT_EQ(whoami.Json().value("principal", ""), "erin");
  EXPECT_EQ(StopDaemon(), 0);
}

}  // namespace
}  // namespace hdrstereo::testing
