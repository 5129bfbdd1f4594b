// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/report/html_report.h"

#include <gtest/gtest.h>

#include <string>

#include "absl/strings/match.h"

namespace hdrstereo::report {
namespace {

TEST(HtmlReportTest, EscapesEveryText) {
  EXPECT_EQ(EscapeHtml("<a href=\"x\">'&'</a>"),
            "&lt;a href=&quot;x&quot;&gt;&#39;&amp;&#39;&lt;/a&gt;");
  Page page;
  page.title = "<script>alert(1)</script>";
  page.summary = {{"camera <x>", "a & b"}};
  Section s;
  s.title = "t\"itle";
  s.figures.push_back({"a\"b.png", "<caption>"});
  s.tables.push_back({"metrics", {"<h>"}, {{"<c>"}, {"1.5"}}});
  page.sections.push_back(s);
  const std::string html = RenderPage(page);
  // The only tags are the page's own: no injected script or element.
  EXPECT_FALSE(absl::StrContains(html, "<script>alert"));
  EXPECT_TRUE(absl::StrContains(html, "&lt;script&gt;alert(1)&lt;/script&gt;"));
  EXPECT_TRUE(
      absl::StrContains(html, "<th>camera &lt;x&gt;</th><td>a &amp; b</td>"));
  EXPECT_TRUE(absl::StrContains(html, "<img src=\"a&quot;b.png\""));
  EXPECT_TRUE(absl::StrContains(html, "<th>&lt;h&gt;</th>"));
  EXPECT_TRUE(absl::StrContains(html, "<td class=\"num\">1.5</td>"));
  EXPECT_TRUE(absl::StrContains(html, "<table id=\"metrics\">"));
}

TEST(HtmlReportTest, LoadsNothingFromElsewhere) {
  Page page;
  page.title = "x";
  Section s;
  s.figures.push_back({"a.png", "a"});
  page.sections.push_back(s);
  const std::string html = RenderPage(page);
  EXPECT_FALSE(absl::StrContains(html, "http"));
  EXPECT_FALSE(absl::StrContains(html, "src=\"/"));
  EXPECT_FALSE(absl::StrContains(html, "<link"));
  EXPECT_TRUE(absl::StrContains(html, "imagesLoaded"));
}

}  // namespace
}  // namespace hdrstereo::report
