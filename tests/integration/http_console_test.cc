// SPDX-License-Identifier: GPL-3.0-or-later
//
// The operator's console as the real daemon serves it over its HTTP edge:
// the console the build made (the web_console target, in
// <build>/share/hdrstereo/web, which is the build tree's hdrstereod's
// default --web-root), byte for byte, with the edge's security headers, a
// sha256 ETag and 304s, HEAD without a body, to anyone (no certificate, no
// cookie, a stale cookie) while the API still needs credentials; no path
// reaches a file outside it; other methods get 405. Without a console, /
// says how to build one; a --web-root that does not exist stops the start.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "processing/io/sha256.h"
#include "tests/integration/http_fixture.h"

namespace hdrstereo::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

// The edge's Content-Security-Policy (daemon/http/http_edge.cc), written
// out: the console's page must load under exactly this.
constexpr char kCsp[] =
    "default-src 'self'; img-src 'self' blob: data:; object-src 'none'; "
    "base-uri 'none'; form-action 'self'; frame-ancestors 'none'";

const fs::path kWebRoot = HDRSTEREO_WEB_ROOT;

std::string Tag(const std::string& bytes) {
  return absl::StrCat("\"", io::Sha256Hex(bytes), "\"");
}

class HttpConsoleTest : public HttpFixture {
 protected:
  // A request as a browser without any credentials sends it.
  HttpRequest Get(const std::string& path, const std::string& method = "GET") {
    HttpRequest request = To(path);
    request.method = method;
    return request;
  }
};

TEST_F(HttpConsoleTest, ServesTheBuiltConsoleToAnyoneByteForByte) {
  ASSERT_TRUE(fs::exists(kWebRoot / "index.html"))
      << kWebRoot << " has no console: build the web_console target";
  StartHttpDaemon();
  EXPECT_THAT(daemon_log(),
              HasSubstr(absl::StrCat("serving the operator's console from ",
                                     kWebRoot.string())));
  const std::string index = ReadFileOrDie(kWebRoot / "index.html");
  HttpResponse page = Fetch(Get("/"));
  ASSERT_EQ(page.status, 200) << page.curl_error << page.body;
  EXPECT_EQ(page.body, index);
  EXPECT_EQ(page.Header("content-type"), "text/html; charset=utf-8");
  EXPECT_EQ(page.Header("cache-control"), "no-cache");
  EXPECT_EQ(page.Header("etag"), Tag(index));
  EXPECT_EQ(page.Header("content-security-policy"), kCsp);
  EXPECT_EQ(page.Header("x-content-type-options"), "nosniff");
  EXPECT_EQ(page.Header("x-frame-options"), "DENY");
  EXPECT_EQ(page.Header("referrer-policy"), "no-referrer");
  EXPECT_EQ(page.Header("set-cookie"), "");
  // Under that CSP the page loads its script and style sheet from this
  // origin, and has nothing inline that the CSP would block.
  EXPECT_THAT(index, HasSubstr(R"(<script type="module" src="/console.js">)"));
  EXPECT_THAT(index,
              HasSubstr(R"(<link rel="stylesheet" href="/console.css">)"));
  EXPECT_THAT(index, Not(HasSubstr("<script>")));
  EXPECT_THAT(index, Not(HasSubstr("<style")));
  EXPECT_THAT(index, Not(HasSubstr("style=")));
  EXPECT_EQ(Fetch(Get("/index.html")).body, index);

  const struct {
    const char* name;
    const char* type;
  } kFiles[] = {{"console.js", "text/javascript; charset=utf-8"},
                {"console.css", "text/css; charset=utf-8"},
                {"console.js.map", "application/json"}};
  for (const auto& [name, type] : kFiles) {
    const std::string bytes = ReadFileOrDie(kWebRoot / name);
    HttpResponse file = Fetch(Get(absl::StrCat("/", name)));
    ASSERT_EQ(file.status, 200) << name << file.body;
    EXPECT_TRUE(file.body == bytes)
        << name << ": " << file.body.size() << " bytes served, " << bytes.size()
        << " on disk";
    EXPECT_EQ(file.Header("content-type"), type) << name;
    EXPECT_EQ(file.Header("etag"), Tag(bytes)) << name;
    EXPECT_EQ(file.Header("content-length"), std::to_string(bytes.size()));
    EXPECT_EQ(file.Header("cache-control"), "no-cache") << name;
    EXPECT_EQ(file.Header("content-security-policy"), kCsp) << name;
  }

  // A stale session cookie and a client certificate change nothing: the
  // page loads for signing in again.
  HttpRequest stale = Get("/");
  stale.headers = {"Cookie: __Host-hdrstereo_session=ended"};
  EXPECT_EQ(Fetch(stale).body, index);
  HttpRequest certified = To("/", "bob");
  certified.method = "GET";
  EXPECT_EQ(Fetch(certified).body, index);
  // The API still needs credentials.
  HttpRequest anonymous = Get("/hdrstereo.v1.Server/WhoAmI", "POST");
  anonymous.headers = {"Content-Type: application/json"};
  anonymous.body = "{}";
  HttpResponse refused = Fetch(anonymous);
  EXPECT_EQ(refused.status, 401);
  EXPECT_THAT(refused.Json().value("message", ""), HasSubstr("no credentials"));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpConsoleTest, IfNoneMatchIs304AndHeadHasNoBody) {
  StartHttpDaemon();
  const std::string js = ReadFileOrDie(kWebRoot / "console.js");
  HttpRequest again = Get("/console.js");
  again.headers = {"If-None-Match: " + Tag(js)};
  HttpResponse not_modified = Fetch(again);
  EXPECT_EQ(not_modified.status, 304);
  EXPECT_EQ(not_modified.body, "");
  EXPECT_EQ(not_modified.Header("etag"), Tag(js));
  EXPECT_EQ(not_modified.Header("cache-control"), "no-cache");
  // A tag of other bytes: the file.
  again.headers = {"If-None-Match: " + Tag(js + " ")};
  EXPECT_EQ(Fetch(again).body, js);

  HttpResponse head = Fetch(Get("/console.js", "HEAD"));
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.body, "");
  EXPECT_EQ(head.Header("content-length"), std::to_string(js.size()));
  EXPECT_EQ(head.Header("etag"), Tag(js));
  EXPECT_EQ(head.Header("content-type"), "text/javascript; charset=utf-8");
  HttpResponse head_index = Fetch(Get("/", "HEAD"));
  EXPECT_EQ(head_index.status, 200);
  EXPECT_EQ(head_index.body, "");
  EXPECT_EQ(head_index.Header("content-length"),
            std::to_string(ReadFileOrDie(kWebRoot / "index.html").size()));
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpConsoleTest, NoPathReachesAFileOutsideTheConsole) {
  StartHttpDaemon();
  // Sent as written (curl would otherwise resolve the dots itself).
  for (const char* path :
       {"/../etc/passwd", "/..%2fetc%2fpasswd", "/%2e%2e/etc/passwd",
        "/%2e%2e%2fetc%2fpasswd", "/./console.js", "//etc/passwd",
        "/console.js/", "/console.js/../index.html", "/.%2e/.%2e/etc/passwd",
        "/etc/passwd", "/passwd", "/hdrstereod", "/CMakeCache.txt",
        "/%2e%2e/%2e%2e/CMakeCache.txt", "/.git/config", "/console.JS"}) {
    HttpRequest request = Get(path);
    request.path_as_is = true;
    HttpResponse response = Fetch(request);
    EXPECT_EQ(response.status, 404) << path << ": " << response.body;
    EXPECT_EQ(response.Json().value("code", ""), "not_found") << path;
    // The edge saw the path as written.
    EXPECT_THAT(response.Json().value("message", ""),
                HasSubstr(absl::StrCat("no such page: \"", path, "\"")));
    EXPECT_THAT(response.body, Not(HasSubstr("root:")));
  }
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpConsoleTest, OtherMethodsAre405WithAllow) {
  StartHttpDaemon();
  for (const auto& [method, path] :
       std::vector<std::pair<std::string, std::string>>{
           {"POST", "/"},
           {"PUT", "/"},
           {"DELETE", "/console.js"},
           {"POST", "/index.html"},
           {"OPTIONS", "/console.css"}}) {
    HttpRequest request = Get(path, method);
    request.headers = {"Content-Type: application/json"};
    request.body = "{}";
    HttpResponse response = Fetch(request);
    EXPECT_EQ(response.status, 405) << method << " " << path;
    EXPECT_EQ(response.Header("allow"), "GET, HEAD") << method << " " << path;
    EXPECT_THAT(response.Json().value("message", ""),
                HasSubstr(absl::StrCat("method ", method,
                                       " is not served here; use GET, HEAD")));
  }
  // A path that is not the console's keeps its answer.
  HttpResponse unknown = Fetch(Get("/nothing.js", "POST"));
  EXPECT_EQ(unknown.status, 404);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpConsoleTest, WithoutAConsoleTheRootSaysHowToBuildOne) {
  const fs::path empty = dir_ / "empty-web";
  fs::create_directory(empty);
  StartHttpDaemon({"--web-root", empty.string()});
  EXPECT_THAT(daemon_log(), HasSubstr(absl::StrCat("no operator's console in ",
                                                   empty.string(),
                                                   " (no index.html there)")));
  HttpResponse root = Fetch(Get("/"));
  EXPECT_EQ(root.status, 404);
  EXPECT_EQ(root.Header("content-type"), "text/plain; charset=utf-8");
  EXPECT_EQ(root.Header("content-security-policy"), kCsp);
  EXPECT_THAT(root.body, HasSubstr("console is not installed"));
  EXPECT_THAT(root.body, HasSubstr("web_console"));
  // The daemon's folders are not shown to anyone who asks.
  EXPECT_THAT(root.body, Not(HasSubstr(empty.string())));
  EXPECT_EQ(Fetch(Get("/console.js")).status, 404);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(HttpConsoleTest, ANamedWebRootThatDoesNotExistStopsTheStart) {
  const fs::path missing = dir_ / "no-such-web";
  absl::StatusOr<CommandResult> run =
      RunCommand({HDRSTEREOD, "--data-root", data_root().string(), "--hardware",
                  "sim", "--listen", "127.0.0.1:0", "--http-listen",
                  "127.0.0.1:0", "--web-root", missing.string()});
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_EQ(run->exit_code, 1);
  EXPECT_THAT(run->err, HasSubstr(absl::StrCat("--web-root ", missing.string(),
                                               ": no such directory")));
}

}  // namespace
}  // namespace hdrstereo::testing
