// SPDX-License-Identifier: GPL-3.0-or-later
//
// The console's files as the HTTP edge serves them, from folders made here:
// what is loaded (types, sha256 ETags), what is skipped (subfolders,
// symbolic links, special, hidden and other files), what is refused (sizes
// beyond the limits, named), the answers (200, 304, 404 not installed,
// 405) and the paths that are not the console's (traversals included).
#include "daemon/http/console_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::http {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::StatusIs;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

// sha256("abc") and sha256("") (FIPS 180-2's example and the empty
// message), quoted as an ETag.
constexpr char kAbcTag[] =
    "\"ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad\"";
constexpr char kEmptyTag[] =
    "\"e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855\"";

void Write(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

class ConsoleFilesTest : public ::testing::Test {
 protected:
  fs::path web() const { return dir_ / "web"; }
  void SetUp() override { fs::create_directory(web()); }
  // index.html, console.js ("abc") and console.css (empty).
  void WriteConsole() {
    Write(web() / "index.html", "<!doctype html><title>t</title>");
    Write(web() / "console.js", "abc");
    Write(web() / "console.css", "");
  }

  testing::TempDir dir_;
};

TEST_F(ConsoleFilesTest, LoadsEachFileWithItsTypeAndSha256Tag) {
  WriteConsole();
  Write(web() / "console.js.map", "{}");
  Write(web() / "data.json", "[]");
  Write(web() / "icon.svg", "<svg/>");
  Write(web() / "logo.png", "png");
  Write(web() / "favicon.ico", "ico");
  Write(web() / "UPPER.JS", "x");
  ASSERT_OK_AND_ASSIGN(ConsoleFiles console, ConsoleFiles::Load(web()));
  EXPECT_TRUE(console.found());
  EXPECT_TRUE(console.installed());
  EXPECT_EQ(console.dir(), web());
  EXPECT_THAT(console.skipped(), IsEmpty());
  EXPECT_EQ(console.files().size(), 9u);
  // 31 + 3 + 0 + 2 + 2 + 6 + 3 + 3 + 1
  EXPECT_EQ(console.total_bytes(), 51u);
  auto type = [&](const std::string& name) {
    return console.files().at(name).content_type;
  };
  EXPECT_EQ(type("index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(type("console.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(type("UPPER.JS"), "text/javascript; charset=utf-8");
  EXPECT_EQ(type("console.css"), "text/css; charset=utf-8");
  EXPECT_EQ(type("console.js.map"), "application/json");
  EXPECT_EQ(type("data.json"), "application/json");
  EXPECT_EQ(type("icon.svg"), "image/svg+xml");
  EXPECT_EQ(type("logo.png"), "image/png");
  EXPECT_EQ(type("favicon.ico"), "image/x-icon");
  const ConsoleFile& js = console.files().at("console.js");
  EXPECT_EQ(js.name, "console.js");
  EXPECT_EQ(js.body, "abc");
  EXPECT_EQ(js.etag, kAbcTag);
  EXPECT_EQ(console.files().at("console.css").etag, kEmptyTag);
}

TEST_F(ConsoleFilesTest, SkipsWhatIsNotAConsoleFileAndFollowsNoLink) {
  WriteConsole();
  // Outside the console: a secret a link points at.
  Write(dir_ / "secret.js", "secret");
  fs::create_directory(web() / "assets");
  Write(web() / "assets" / "nested.js", "nested");
  fs::create_symlink(dir_ / "secret.js", web() / "linked.js");
  fs::create_directory_symlink(dir_.path(), web() / "up");
  Write(web() / ".hidden.js", "hidden");
  Write(web() / "two words.js", "odd");
  Write(web() / "README.txt", "text");
  Write(web() / "noextension", "none");
  // A FIFO: opening it for reading would block the start.
  ASSERT_EQ(::mkfifo((web() / "pipe.js").c_str(), 0600), 0);
  ASSERT_OK_AND_ASSIGN(ConsoleFiles console, ConsoleFiles::Load(web()));
  EXPECT_EQ(console.files().size(), 3u);
  EXPECT_EQ(console.total_bytes(), 34u);
  constexpr char kNotAType[] =
      ": not a type the console has (.html, .js, .css, .map, .json, .svg, "
      ".png, .ico)";
  constexpr char kOddName[] =
      ": a hidden file or a name with characters other than letters, "
      "digits, '.', '_' and '-'";
  EXPECT_THAT(
      console.skipped(),
      ElementsAre(
          std::string(".hidden.js") + kOddName,
          std::string("README.txt") + kNotAType,
          "assets: a directory (only files directly in the console directory "
          "are served)",
          "linked.js: a symbolic link (links are not followed)",
          std::string("noextension") + kNotAType, "pipe.js: not a regular file",
          std::string("two words.js") + kOddName,
          "up: a symbolic link (links are not followed)"));
  for (const char* path :
       {"/linked.js", "/assets/nested.js", "/up/secret.js", "/.hidden.js",
        "/README.txt", "/pipe.js", "/secret.js"}) {
    EXPECT_FALSE(console.Serves(path)) << path;
    EXPECT_EQ(console.Answer("GET", path, ""), std::nullopt) << path;
  }
}

TEST_F(ConsoleFilesTest, AFileBeyondTheLimitIsRefusedNamingItsSize) {
  Write(web() / "a.css", "small");
  Write(web() / "big.js", std::string(11, 'x'));
  ConsoleLimits limits;
  limits.max_file_bytes = 10;
  EXPECT_THAT(ConsoleFiles::Load(web(), limits),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "the console file " + (web() / "big.js").string() +
                           " is 11 bytes, more than the limit of 10 bytes "
                           "per file"));
  // At the limit it loads.
  limits.max_file_bytes = 11;
  EXPECT_OK(ConsoleFiles::Load(web(), limits));
}

TEST_F(ConsoleFilesTest, AConsoleBeyondTheTotalIsRefusedNamingTheFile) {
  Write(web() / "a.js", "123456");
  Write(web() / "b.js", "123456");
  ConsoleLimits limits;
  limits.max_total_bytes = 11;
  EXPECT_THAT(ConsoleFiles::Load(web(), limits),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "the console in " + web().string() +
                           " is more than the limit of 11 bytes in all: b.js "
                           "(6 bytes) comes after 6 bytes of other files"));
  limits.max_total_bytes = 12;
  ASSERT_OK_AND_ASSIGN(ConsoleFiles console, ConsoleFiles::Load(web(), limits));
  EXPECT_EQ(console.total_bytes(), 12u);
  // No index.html: nothing at /.
  EXPECT_FALSE(console.installed());
}

TEST_F(ConsoleFilesTest, TooManyEntriesAreRefused) {
  WriteConsole();
  ConsoleLimits limits;
  limits.max_entries = 2;
  EXPECT_THAT(
      ConsoleFiles::Load(web(), limits),
      StatusIs(absl::StatusCode::kInvalidArgument,
               "the console directory " + web().string() +
                   " holds more than 2 entries, the limit (a built console "
                   "is a handful of files)"));
  limits.max_entries = 3;
  EXPECT_OK(ConsoleFiles::Load(web(), limits));
}

TEST_F(ConsoleFilesTest, AMissingDirectoryIsTheNotInstalledAnswer) {
  ASSERT_OK_AND_ASSIGN(ConsoleFiles console,
                       ConsoleFiles::Load(dir_ / "no-such"));
  EXPECT_FALSE(console.found());
  EXPECT_FALSE(console.installed());
  std::optional<ConsoleAnswer> answer = console.Answer("GET", "/", "");
  ASSERT_TRUE(answer.has_value());
  EXPECT_EQ(answer->status, 404);
  EXPECT_EQ(answer->file, nullptr);
  EXPECT_EQ(answer->message, kConsoleNotInstalled);
  EXPECT_THAT(answer->message, HasSubstr("not installed"));
  EXPECT_THAT(answer->message, HasSubstr("web_console"));
  EXPECT_THAT(answer->message, HasSubstr("--web-root"));
  // The message names no folder of the daemon's machine.
  EXPECT_THAT(answer->message, ::testing::Not(HasSubstr(dir_.path().string())));
  // A default-constructed one is the same.
  EXPECT_EQ(ConsoleFiles().Answer("HEAD", "/", "")->status, 404);
  // Other paths are not the console's: the edge's 404.
  EXPECT_EQ(console.Answer("GET", "/console.js", ""), std::nullopt);
  EXPECT_EQ(console.Answer("POST", "/", "")->status, 405);
}

TEST_F(ConsoleFilesTest, AFileIsNoConsoleDirectory) {
  Write(dir_ / "file", "x");
  EXPECT_THAT(ConsoleFiles::Load(dir_ / "file"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "the console directory " + (dir_ / "file").string() +
                           " is not a directory"));
}

TEST_F(ConsoleFilesTest, TheDirectoryItselfMayBeALink) {
  WriteConsole();
  fs::create_directory_symlink(web(), dir_ / "link");
  ASSERT_OK_AND_ASSIGN(ConsoleFiles console, ConsoleFiles::Load(dir_ / "link"));
  EXPECT_TRUE(console.installed());
  EXPECT_EQ(console.files().size(), 3u);
}

TEST_F(ConsoleFilesTest, Answers) {
  WriteConsole();
  ASSERT_OK_AND_ASSIGN(ConsoleFiles console, ConsoleFiles::Load(web()));
  auto status = [&](absl::string_view method, absl::string_view path,
                    absl::string_view if_none_match = "") {
    std::optional<ConsoleAnswer> answer =
        console.Answer(method, path, if_none_match);
    return answer.has_value() ? answer->status : 0;
  };
  std::optional<ConsoleAnswer> index = console.Answer("GET", "/", "");
  ASSERT_TRUE(index.has_value());
  EXPECT_EQ(index->status, 200);
  ASSERT_NE(index->file, nullptr);
  EXPECT_EQ(index->file->name, "index.html");
  EXPECT_EQ(console.Answer("HEAD", "/console.js", "")->file->body, "abc");
  EXPECT_EQ(status("GET", "/index.html"), 200);
  EXPECT_EQ(status("HEAD", "/console.css"), 200);
  // If-None-Match: the tag, weak or in a list, or *; another tag is a 200.
  EXPECT_EQ(status("GET", "/console.js", kAbcTag), 304);
  EXPECT_EQ(status("GET", "/console.js", std::string("W/") + kAbcTag), 304);
  EXPECT_EQ(
      status("GET", "/console.js", std::string("\"other\", ") + kAbcTag + " "),
      304);
  EXPECT_EQ(status("HEAD", "/console.js", "*"), 304);
  EXPECT_EQ(status("GET", "/console.js", kEmptyTag), 200);
  EXPECT_EQ(status("GET", "/console.js", "\"abc\""), 200);
  EXPECT_EQ(console.Answer("GET", "/console.js", kAbcTag)->file->etag, kAbcTag);
  // Other methods.
  for (const char* method : {"POST", "PUT", "DELETE", "OPTIONS", "get"}) {
    EXPECT_EQ(status(method, "/"), 405) << method;
    EXPECT_EQ(status(method, "/console.js"), 405) << method;
  }
  // Not the console's: names not loaded, any path with another '/', and
  // percent-encoded ones (never decoded, never a file path).
  for (const char* path :
       {"", "index.html", "/nothing.js", "/console.js/", "//console.js",
        "/./console.js", "/../etc/passwd", "/%2e%2e/etc/passwd",
        "/%2E%2E%2Fetc%2Fpasswd", "/..%2fetc%2fpasswd", "/console%2ejs",
        "/hdrstereo.v1.Jobs/List", "/files/sessions/s/frames/1",
        "/auth/sign-in"}) {
    EXPECT_FALSE(console.Serves(path)) << path;
    EXPECT_EQ(console.Answer("GET", path, ""), std::nullopt) << path;
    EXPECT_EQ(console.Answer("POST", path, ""), std::nullopt) << path;
  }
}

TEST(ConsoleContentTypeTest, ByExtensionOnly) {
  EXPECT_EQ(ConsoleContentType("a.HTML"), "text/html; charset=utf-8");
  EXPECT_EQ(ConsoleContentType("a.b.css"), "text/css; charset=utf-8");
  EXPECT_EQ(ConsoleContentType("html"), std::nullopt);
  EXPECT_EQ(ConsoleContentType("a.htm"), std::nullopt);
  EXPECT_EQ(ConsoleContentType("a.js.gz"), std::nullopt);
  EXPECT_EQ(ConsoleContentType("a."), std::nullopt);
}

TEST(EntityTagTest, IsTheQuotedSha256Hex) {
  EXPECT_EQ(EntityTagOf("abc"), kAbcTag);
  EXPECT_EQ(EntityTagOf(""), kEmptyTag);
}

TEST(IfNoneMatchTest, ComparesWeaklyInAList) {
  EXPECT_TRUE(IfNoneMatchMatches("\"x\"", "\"x\""));
  EXPECT_TRUE(IfNoneMatchMatches("W/\"x\"", "\"x\""));
  EXPECT_TRUE(IfNoneMatchMatches(" \"a\" ,\t\"x\"", "\"x\""));
  EXPECT_TRUE(IfNoneMatchMatches("*", "\"x\""));
  EXPECT_FALSE(IfNoneMatchMatches("", "\"x\""));
  EXPECT_FALSE(IfNoneMatchMatches("x", "\"x\""));
  EXPECT_FALSE(IfNoneMatchMatches("\"X\"", "\"x\""));
  EXPECT_FALSE(IfNoneMatchMatches("\"a\", \"b\"", "\"x\""));
  EXPECT_FALSE(IfNoneMatchMatches(",", "\"x\""));
}

TEST(WebRootTest, IsShareBesideTheExecutablesFolder) {
  EXPECT_EQ(WebRootBeside("/usr/local/bin/hdrstereod"),
            "/usr/local/share/hdrstereo/web");
  EXPECT_EQ(WebRootBeside("/work/main/build/daemon/hdrstereod"),
            "/work/main/build/share/hdrstereo/web");
  // This test's own executable, in the build tree.
  const fs::path root = DefaultWebRoot();
  EXPECT_TRUE(root.is_absolute()) << root;
  EXPECT_EQ(root, WebRootBeside(fs::read_symlink("/proc/self/exe")));
}

}  // namespace
}  // namespace hdrstereo::http
