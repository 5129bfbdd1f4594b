// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/report/html_report.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace hdrstereo::report {

std::string EscapeHtml(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

namespace {

constexpr char kStyle[] = R"(
body { font-family: sans-serif; margin: 1.5em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.5em; }
table { border-collapse: collapse; margin: 0.5em 0; }
td, th { border: 1px solid #bbb; padding: 0.2em 0.6em; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
figure { display: inline-block; margin: 0.3em; vertical-align: top; }
figure img { max-width: 320px; image-rendering: pixelated; display: block; }
figcaption { font-size: 0.8em; text-align: center; }
)";

// Counts decoded images once everything has loaded (see the header).
constexpr char kScript[] = R"(
window.addEventListener('load', function () {
  var images = document.images, loaded = 0;
  for (var i = 0; i < images.length; ++i) {
    if (images[i].complete && images[i].naturalWidth > 0) ++loaded;
  }
  document.body.dataset.imagesLoaded = loaded + '/' + images.length;
});
)";

bool LooksNumeric(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (!((c >= '0' && c <= '9') || c == '.' || c == '-' || c == '+' ||
          c == 'e')) {
      return false;
    }
  }
  return true;
}

void AppendTable(const Table& t, std::string* out) {
  absl::StrAppend(out, "<table id=\"", EscapeHtml(t.id), "\">\n<tr>");
  for (const std::string& h : t.header) {
    absl::StrAppend(out, "<th>", EscapeHtml(h), "</th>");
  }
  absl::StrAppend(out, "</tr>\n");
  for (const std::vector<std::string>& row : t.rows) {
    absl::StrAppend(out, "<tr>");
    for (const std::string& cell : row) {
      absl::StrAppend(out, LooksNumeric(cell) ? "<td class=\"num\">" : "<td>",
                      EscapeHtml(cell), "</td>");
    }
    absl::StrAppend(out, "</tr>\n");
  }
  absl::StrAppend(out, "</table>\n");
}

}  // namespace

std::string RenderPage(const Page& page) {
  std::string out = absl::StrCat(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<title>",
      EscapeHtml(page.title), "</title>\n<style>", kStyle, "</style>\n<script>",
      kScript, "</script>\n</head>\n<body>\n<h1>", EscapeHtml(page.title),
      "</h1>\n");
  if (!page.summary.empty()) {
    absl::StrAppend(&out, "<table id=\"summary\">\n");
    for (const auto& [key, value] : page.summary) {
      absl::StrAppend(&out, "<tr><th>", EscapeHtml(key), "</th><td>",
                      EscapeHtml(value), "</td></tr>\n");
    }
    absl::StrAppend(&out, "</table>\n");
  }
  for (const Section& s : page.sections) {
    absl::StrAppend(&out, "<section>\n<h2>", EscapeHtml(s.title), "</h2>\n");
    if (!s.text.empty())
      absl::StrAppend(&out, "<p>", EscapeHtml(s.text), "</p>\n");
    for (const Table& t : s.tables) AppendTable(t, &out);
    for (const Figure& f : s.figures) {
      absl::StrAppend(&out, "<figure><img src=\"", EscapeHtml(f.file),
                      "\" alt=\"", EscapeHtml(f.caption), "\"><figcaption>",
                      EscapeHtml(f.caption), "</figcaption></figure>\n");
    }
    absl::StrAppend(&out, "</section>\n");
  }
  absl::StrAppend(&out, "</body>\n</html>\n");
  return out;
}

}  // namespace hdrstereo::report
