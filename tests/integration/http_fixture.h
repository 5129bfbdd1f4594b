// SPDX-License-Identifier: GPL-3.0-or-later
//
// The real hdrstereod serving gRPC over TLS (RemoteFixture) and its HTTP
// edge over TLS on 127.0.0.1:<free port>, with the certificates of
// TestCerts; requests go through libcurl (tests/support/http_client.h).
#ifndef HDRSTEREO_TESTS_INTEGRATION_HTTP_FIXTURE_H_
#define HDRSTEREO_TESTS_INTEGRATION_HTTP_FIXTURE_H_

#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "tests/integration/remote_fixture.h"
#include "tests/support/http_client.h"

namespace hdrstereo::testing {

class HttpFixture : public RemoteFixture {
 protected:
  // gRPC: TLS on 0.0.0.0:0 (and, with `local_port`, 127.0.0.1:0 plain);
  // HTTP: TLS on 127.0.0.1:0.
  void StartHttpDaemon(std::vector<std::string> extra = {},
                       bool local_port = false) {
    extra.insert(extra.begin(), {"--http-listen", "127.0.0.1:0"});
    StartTlsDaemon(extra, local_port);
    ASSERT_FALSE(http_urls_.empty()) << "no HTTP address in the ready file";
    // The server certificate names localhost and 127.0.0.1.
    base_ = http_urls_[0];
  }

  // A request to `path` as `user` (its client certificate; "" = none),
  // trusting the lab CA.
  HttpRequest To(const std::string& path, const std::string& user = "") {
    HttpRequest request;
    request.url = base_ + path;
    request.ca = certs_.ca();
    if (!user.empty()) {
      request.cert = certs_.Cert(user);
      request.key = certs_.Key(user);
    }
    return request;
  }

  // A unary Connect call with a JSON body.
  HttpResponse Unary(const std::string& method, const std::string& json,
                     const std::string& user,
                     std::vector<std::string> headers = {}) {
    HttpRequest request = To(absl::StrCat("/hdrstereo.v1.", method), user);
    request.headers = std::move(headers);
    request.headers.push_back("Content-Type: application/json");
    request.body = json;
    return Fetch(request);
  }

  // Creates `session` and submits a bracketed stereo capture of it at
  // `exposures` (a JSON list of seconds) as bob (operator), over HTTP; the
  // job's id, "" when refused (a test failure).
  std::string SubmitStereoCapture(const std::string& session,
                                  const std::string& exposures) {
    HttpResponse created =
        Unary("Sessions/Create",
              absl::StrCat(R"({"name": ")", session, R"("})"), "bob");
    EXPECT_EQ(created.status, 200) << created.body;
    HttpResponse submitted =
        Unary("Jobs/SubmitCapture",
              absl::StrCat(R"({"session": ")", session,
                           R"(", "plan": {"bracketedStereo": {"exposuresS": )",
                           exposures, "}}}"),
              "bob");
    EXPECT_EQ(submitted.status, 200) << submitted.body;
    return submitted.Json().value("id", "");
  }

  // Follows job `id` with Jobs/Watch (a Connect stream) to its end, as
  // `user`; its last state ("JOB_STATE_SUCCEEDED"), "" when none came.
  std::string FinalState(const std::string& id, const std::string& user) {
    HttpRequest watch = To("/hdrstereo.v1.Jobs/Watch", user);
    watch.headers = {"Content-Type: application/connect+json"};
    watch.body = EnvelopeOf(absl::StrCat(R"({"jobId": ")", id, R"("})"));
    watch.timeout = absl::Seconds(120);
    std::string state;
    for (const StreamMessage& message : ParseEnvelopes(Fetch(watch).body)) {
      if (message.end) break;
      state = nlohmann::json::parse(message.payload).value("state", state);
    }
    return state;
  }

  // An API key made by carol (admin) with the CLI; "" on failure.
  std::string CreateKey(const std::string& user, const std::string& role) {
    CommandResult created =
        As("carol", {"admin", "key", "create", "--user", user, "--role", role});
    EXPECT_EQ(created.exit_code, 0) << created.err;
    return std::string(absl::StripAsciiWhitespace(created.out));
  }

  std::string base_;  // "https://127.0.0.1:PORT"
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_INTEGRATION_HTTP_FIXTURE_H_
