// SPDX-License-Identifier: GPL-3.0-or-later
//
// One self-contained HTML page: a title, a key/value summary, sections of
// captioned images (files beside the page, referenced by relative name),
// and tables. Every text is HTML-escaped; the page loads nothing from
// elsewhere (no CDN, no fonts, no scripts but its own).
//
// After the window's load event an inline script sets
//   <body data-images-loaded="LOADED/TOTAL">
// where an image counts as loaded when it is complete with a non-zero
// natural width, so a headless browser's dumped DOM tells whether every
// image could be decoded.
#ifndef HDRSTEREO_PROCESSING_REPORT_HTML_REPORT_H_
#define HDRSTEREO_PROCESSING_REPORT_HTML_REPORT_H_

#include <string>
#include <utility>
#include <vector>

namespace hdrstereo::report {

struct Figure {
  std::string file;  // relative to the page, e.g. "disp_fused.png"
  std::string caption;
};

struct Table {
  std::string id;  // HTML id of the <table>, e.g. "metrics"
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

struct Section {
  std::string title;
  std::string text;  // a paragraph before the figures; optional
  std::vector<Figure> figures;
  std::vector<Table> tables;
};

struct Page {
  std::string title;
  std::vector<std::pair<std::string, std::string>> summary;
  std::vector<Section> sections;
};

// &, <, >, " and ' replaced by entities.
std::string EscapeHtml(const std::string& text);

std::string RenderPage(const Page& page);

}  // namespace hdrstereo::report

#endif  // HDRSTEREO_PROCESSING_REPORT_HTML_REPORT_H_
