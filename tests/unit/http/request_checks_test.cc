// SPDX-License-Identifier: GPL-3.0-or-later
//
// The header checks that decide whether the HTTP edge serves a request:
// Host against DNS rebinding, Origin against cross-site requests, the
// session cookie, a download's Range, and a report file's name.
#include "daemon/http/request_checks.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::http {
namespace {

using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

TEST(HostNameTest, IsTheNameWithoutThePortLowerCased) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"lab-pc", "lab-pc"},
      {"Lab-PC:8443", "lab-pc"},
      {"rig_1.lab.example.org:80", "rig_1.lab.example.org"},
      {"192.168.1.10:8080", "192.168.1.10"},
      {"lab:0", "lab"},
      {"lab:65535", "lab"},
      {"lab:00080", "lab"},
      {"[::1]", "[::1]"},
      {"[::1]:8443", "[::1]"},
      {"[FE80::ABCD:1]:80", "[fe80::abcd:1]"},
      {"[::ffff:192.168.1.10]", "[::ffff:192.168.1.10]"},
      {std::string(300, 'A'), std::string(300, 'a')},
  };
  for (const auto& [header, name] : cases) {
    ASSERT_OK_AND_ASSIGN(std::string parsed, HostName(header));
    EXPECT_EQ(parsed, name) << header;
  }
}

TEST(HostNameTest, MalformedHeadersAreRefusedQuotingThem) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", R"("")"},
      {":8443", R"(":8443")"},
      {"lab:", R"("lab:")"},
      {"lab:65536", R"("lab:65536")"},
      {"lab:123456", R"("lab:123456")"},
      {"lab:-1", R"("lab:-1")"},
      {"lab:+80", R"("lab:+80")"},
      {"lab:80:90", R"("lab:80:90")"},
      {"lab: 80", R"("lab: 80")"},
      {"lab pc", R"("lab pc")"},
      {"lab/x", R"("lab/x")"},
      {"user@lab", R"("user@lab")"},
      {"lab\r\nX-Evil: 1", R"("lab\r\nX-Evil: 1")"},
      {std::string("lab\0pc", 6), R"("lab\x00pc")"},
      {"l\xc3\xa4"
       "b",
       R"("l\xc3\xa4\x62")"},
      {"[::1", R"("[::1")"},
      {"[]", R"("[]")"},
      {"[]:80", R"("[]:80")"},
      {"[::1]x", R"("[::1]x")"},
      {"[::1]:", R"("[::1]:")"},
      {"[::1]:99999", R"("[::1]:99999")"},
      {"[::g]", R"("[::g]")"},
      {"[fe80::1%25eth0]", R"("[fe80::1%25eth0]")"},
  };
  for (const auto& [header, quoted] : cases) {
    EXPECT_THAT(HostName(header),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         "the Host header " + quoted + " is not HOST[:PORT]"))
        << header;
  }
}

TEST(HostNameTest, AHeaderOver300BytesIsRefusedQuotingABoundedPrefix) {
  EXPECT_THAT(HostName(std::string(301, 'a')),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "the Host header \"" + std::string(64, 'a') +
                           "\"... (301 bytes) is not HOST[:PORT]"));
  EXPECT_THAT(HostName(std::string(100000, 'a') + ":80"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("\"... (100003 bytes) is not HOST[:PORT]")));
}

const std::vector<std::string> kServed = {"lab-pc", "127.0.0.1", "[::1]"};

TEST(CheckHostTest, ServedNamesAreAcceptedWithAnyPortAndCase) {
  for (const char* header :
       {"lab-pc", "LAB-PC:8443", "127.0.0.1:8080", "[::1]:8443", "[::1]"}) {
    EXPECT_OK(CheckHost(header, kServed)) << header;
  }
}

TEST(CheckHostTest, ARebindingNameIsRefusedNamingTheServedOnes) {
  EXPECT_THAT(
      CheckHost("Evil.Example:8443", kServed),
      StatusIs(absl::StatusCode::kPermissionDenied,
               "hdrstereod is not served under the name \"evil.example\"; it "
               "answers to lab-pc, 127.0.0.1, [::1] (add the name with "
               "http-host in its configuration)"));
  // A name that only starts or ends like a served one.
  for (const char* header : {"lab-pc.evil.example", "xlab-pc", "lab-pc.",
                             "127.0.0.1.nip.io", "[::2]"}) {
    EXPECT_THAT(CheckHost(header, kServed),
                StatusIs(absl::StatusCode::kPermissionDenied,
                         HasSubstr("hdrstereod is not served under the name")))
        << header;
  }
  EXPECT_THAT(CheckHost("lab-pc", {}),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       HasSubstr("not served under the name \"lab-pc\"")));
}

TEST(CheckHostTest, AMalformedHostIsPermissionDeniedSayingWhy) {
  EXPECT_THAT(CheckHost("", kServed),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       "the Host header \"\" is not HOST[:PORT]"));
  EXPECT_THAT(CheckHost("lab-pc:99999", kServed),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       "the Host header \"lab-pc:99999\" is not HOST[:PORT]"));
}

TEST(CheckOriginTest, TheRequestsOwnOriginIsAccepted) {
  EXPECT_OK(CheckOrigin("http://lab-pc:8080", "http", "lab-pc:8080"));
  EXPECT_OK(CheckOrigin("https://lab-pc", "https", "lab-pc"));
  EXPECT_OK(CheckOrigin("HTTPS://Lab-PC:8443", "https", "lab-pc:8443"));
  EXPECT_OK(CheckOrigin("https://[::1]:8443", "https", "[::1]:8443"));
}

TEST(CheckOriginTest, AnotherSchemePortOrHostIsRefusedNamingBoth) {
  EXPECT_THAT(CheckOrigin("https://evil.example", "https", "lab-pc:8443"),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       "a request from the page of \"https://evil.example\" "
                       "may not change anything on \"https://lab-pc:8443\" "
                       "(cross-site requests are refused)"));
  const std::vector<std::string> others = {
      "http://lab-pc:8443",           // scheme
      "https://lab-pc:8444",          // port
      "https://lab-pc",               // port left out
      "https://lab-pc.evil:8443",     // host
      "https://lab-pc:8443/",         // not an origin
      "https://lab-pc:8443.evil",     // suffix
      "null",                         // sandboxed or file: pages
      "",                             // sent empty
      "https://lab-pc:8443\r\nX: y",  // header injection
  };
  for (const std::string& origin : others) {
    EXPECT_THAT(CheckOrigin(origin, "https", "lab-pc:8443"),
                StatusIs(absl::StatusCode::kPermissionDenied,
                         HasSubstr("(cross-site requests are refused)")))
        << origin;
  }
  EXPECT_THAT(CheckOrigin("null", "http", "lab-pc"),
              StatusIs(absl::StatusCode::kPermissionDenied,
                       "a request from the page of \"null\" may not change "
                       "anything on \"http://lab-pc\" (cross-site requests "
                       "are refused)"));
}

TEST(CheckOriginTest, AHugeOriginIsQuotedBounded) {
  EXPECT_THAT(
      CheckOrigin(std::string(5000, 'o'), "http", "lab-pc"),
      StatusIs(absl::StatusCode::kPermissionDenied,
               "a request from the page of \"" + std::string(64, 'o') +
                   "\"... (5000 bytes) may not change anything on "
                   "\"http://lab-pc\" (cross-site requests are refused)"));
}

constexpr char kCookie[] = "hdrstereo_session";

TEST(CookieValueTest, FindsTheNamedCookieAmongOthers) {
  EXPECT_EQ(CookieValue("a=1; hdrstereo_session=abc; b=2", kCookie), "abc");
  EXPECT_EQ(CookieValue("hdrstereo_session=abc", kCookie), "abc");
  EXPECT_EQ(CookieValue("a=1;hdrstereo_session=abc;b=2", kCookie), "abc");
  EXPECT_EQ(CookieValue("  hdrstereo_session =  abc  ;  b=2", kCookie), "abc");
  EXPECT_EQ(CookieValue("hdrstereo_session=\"abc\"", kCookie), "abc");
  EXPECT_EQ(CookieValue("hdrstereo_session=a=b", kCookie), "a=b");
  EXPECT_EQ(CookieValue("hdrstereo_session=", kCookie), "");
  EXPECT_EQ(CookieValue("hdrstereo_session=\"", kCookie), "\"");
  // The first of two is taken (RFC 6265 orders the more specific first).
  EXPECT_EQ(
      CookieValue("hdrstereo_session=one; hdrstereo_session=two", kCookie),
      "one");
  EXPECT_EQ(CookieValue("junk; hdrstereo_session=abc", kCookie), "abc");
}

TEST(CookieValueTest, ACookieWhoseNameOnlyContainsTheNameIsNotIt) {
  EXPECT_EQ(
      CookieValue("xhdrstereo_session=evil; hdrstereo_session=good", kCookie),
      "good");
  EXPECT_EQ(CookieValue("xhdrstereo_session=evil", kCookie), std::nullopt);
  EXPECT_EQ(CookieValue("hdrstereo_session_old=evil", kCookie), std::nullopt);
  EXPECT_EQ(CookieValue("a=hdrstereo_session=evil", kCookie), std::nullopt);
}

TEST(CookieValueTest, AnAbsentCookieIsNullopt) {
  EXPECT_EQ(CookieValue("", kCookie), std::nullopt);
  EXPECT_EQ(CookieValue("a=1; b=2", kCookie), std::nullopt);
  EXPECT_EQ(CookieValue("hdrstereo_session", kCookie), std::nullopt);
  EXPECT_EQ(CookieValue(";;;", kCookie), std::nullopt);
}

void ExpectRange(absl::string_view header, int64_t first,
                 std::optional<int64_t> last) {
  const std::optional<ByteRange> range = ParseRange(header);
  ASSERT_TRUE(range.has_value()) << header;
  EXPECT_EQ(range->first, first) << header;
  EXPECT_EQ(range->last, last) << header;
}

TEST(ParseRangeTest, ASingleRangeFromAByteOnIsRead) {
  ExpectRange("bytes=0-", 0, std::nullopt);
  ExpectRange("bytes=100-", 100, std::nullopt);
  ExpectRange("bytes=10-19", 10, 19);
  ExpectRange("bytes=5-5", 5, 5);
  ExpectRange(" bytes= 10-19 ", 10, 19);
  // 18 digits: the most that cannot overflow an int64.
  ExpectRange("bytes=999999999999999999-", 999999999999999999, std::nullopt);
  ExpectRange("bytes=0-999999999999999999", 0, 999999999999999999);
}

TEST(ParseRangeTest, AnythingElseIsTheWholeFile) {
  for (const char* header : {
           "", "bytes=", "bytes=-",
           "bytes=-500",                        // a suffix range
           "bytes=0-1,5-6",                     // several ranges
           "bytes=0-1, 5-6",                    //
           "items=0-1",                         // another unit
           "bytes 0-1",                         //
           "bytes=5-4",                         // last before first
           "bytes=a-b",                         //
           "bytes=1-2-3",                       //
           "bytes=+5-",                         //
           "bytes=0x10-",                       //
           "bytes=1 -2",                        //
           "bytes=9999999999999999999-",        // 19 digits
           "bytes=0-99999999999999999999",      // 20 digits
           "bytes=99999999999999999999999999-"  //
       }) {
    EXPECT_EQ(ParseRange(header), std::nullopt) << header;
  }
}

void ExpectResolved(const ByteRange& range, int64_t total, int64_t offset,
                    int64_t length) {
  ASSERT_OK_AND_ASSIGN(ResolvedRange resolved, ResolveRange(range, total));
  EXPECT_EQ(resolved.offset, offset);
  EXPECT_EQ(resolved.length, length);
}

TEST(ResolveRangeTest, TheRangeIsClippedToTheFile) {
  ExpectResolved({0, std::nullopt}, 100, 0, 100);
  ExpectResolved({10, 19}, 100, 10, 10);
  ExpectResolved({99, std::nullopt}, 100, 99, 1);
  ExpectResolved({99, 99}, 100, 99, 1);
  ExpectResolved({90, 200}, 100, 90, 10);
  ExpectResolved({0, 999999999999999999}, 100, 0, 100);
}

TEST(ResolveRangeTest, ARangeStartingAtOrBeyondTheEndIsOutOfRange) {
  EXPECT_THAT(ResolveRange({100, std::nullopt}, 100),
              StatusIs(absl::StatusCode::kOutOfRange,
                       "the range starts at byte 100 but the file has 100 "
                       "bytes"));
  EXPECT_THAT(ResolveRange({0, std::nullopt}, 0),
              StatusIs(absl::StatusCode::kOutOfRange,
                       "the range starts at byte 0 but the file has 0 bytes"));
  EXPECT_THAT(ResolveRange({999999999999999999, 999999999999999999}, 100),
              StatusIs(absl::StatusCode::kOutOfRange,
                       "the range starts at byte 999999999999999999 but the "
                       "file has 100 bytes"));
}

TEST(ResolveRangeTest, WhatParseRangeReadsResolvesWithinTheFile) {
  for (const char* header : {"bytes=0-", "bytes=3-", "bytes=3-4", "bytes=9-9",
                             "bytes=0-999999999999999999"}) {
    const std::optional<ByteRange> range = ParseRange(header);
    ASSERT_TRUE(range.has_value()) << header;
    ASSERT_OK_AND_ASSIGN(ResolvedRange resolved, ResolveRange(*range, 10));
    EXPECT_GE(resolved.offset, 0) << header;
    EXPECT_GE(resolved.length, 1) << header;
    EXPECT_LE(resolved.offset + resolved.length, 10) << header;
  }
}

TEST(ReportFilePathTest, APlainNameIsAFileOfTheReportFolder) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"index.html", "report/index.html"},
      {"error_simulation_fused.png", "report/error_simulation_fused.png"},
      {"gt_structured_light_invalid.png",
       "report/gt_structured_light_invalid.png"},
      {"a", "report/a"},
      {"x..y", "report/x..y"},
      {std::string(128, 'n'), absl::StrCat("report/", std::string(128, 'n'))},
  };
  for (const auto& [name, path] : cases) {
    ASSERT_OK_AND_ASSIGN(std::string resolved, ReportFilePath(name));
    EXPECT_EQ(resolved, path);
  }
}

TEST(ReportFilePathTest, AnythingButOnePlainNameIsNotFoundSayingWhy) {
  EXPECT_THAT(
      ReportFilePath(".."),
      StatusIs(absl::StatusCode::kNotFound,
               "no such report file: \"..\" (a report file is named by one "
               "plain name of at most 128 letters, digits, '.', '-' and '_', "
               "not starting with '.', as in "
               "/files/sessions/<session>/report/index.html)"));
  for (const std::string& name :
       {std::string(""), std::string("."), std::string("../index.html"),
        std::string("a/b.png"), std::string("/index.html"),
        std::string("..\\sessions.db"), std::string("index.html\0x", 12),
        std::string(".hidden"), std::string("%2e%2e"),
        std::string("index.html "), std::string("in\ndex.html"),
        std::string(129, 'n')}) {
    EXPECT_THAT(
        ReportFilePath(name),
        StatusIs(absl::StatusCode::kNotFound, HasSubstr("no such report file")))
        << name;
  }
}

}  // namespace
}  // namespace hdrstereo::http
