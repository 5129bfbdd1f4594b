// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/http/request_checks.h"

#include "absl/algorithm/container.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "processing/base/input_limits.h"

namespace hdrstereo::http {
namespace {

// Longer than any DNS name (253) with a port.
constexpr size_t kMaxHostHeaderBytes = 300;
// Longer than any name the report step gives its files.
constexpr size_t kMaxReportNameBytes = 128;

bool IsHostChar(char c) {
  return absl::ascii_isalnum(c) || c == '-' || c == '.' || c == '_';
}

absl::Status BadHost(absl::string_view host_header) {
  return absl::InvalidArgumentError(absl::StrCat(
      "the Host header ", QuoteInput(host_header), " is not HOST[:PORT]"));
}

// A decimal number in [0, 65535].
bool IsPort(absl::string_view text) {
  int port = 0;
  return !text.empty() && text.size() <= 5 &&
         absl::c_all_of(text, absl::ascii_isdigit) &&
         absl::SimpleAtoi(text, &port) && port <= 65535;
}

// A non-negative decimal number of at most 18 digits (no int64 overflow).
std::optional<int64_t> Offset(absl::string_view text) {
  int64_t value = 0;
  if (text.empty() || text.size() > 18 ||
      !absl::c_all_of(text, absl::ascii_isdigit) ||
      !absl::SimpleAtoi(text, &value)) {
    return std::nullopt;
  }
  return value;
}

}  // namespace

absl::StatusOr<std::string> HostName(absl::string_view host_header) {
  if (host_header.empty() || host_header.size() > kMaxHostHeaderBytes) {
    return BadHost(host_header);
  }
  absl::string_view name = host_header;
  absl::string_view port;
  if (name.front() == '[') {
    // An IPv6 literal.
    const size_t close = name.find(']');
    if (close == name.npos) return BadHost(host_header);
    absl::string_view inside = name.substr(1, close - 1);
    if (inside.empty() || !absl::c_all_of(inside, [](char c) {
          return absl::ascii_isxdigit(c) || c == ':' || c == '.';
        })) {
      return BadHost(host_header);
    }
    absl::string_view rest = name.substr(close + 1);
    name = name.substr(0, close + 1);
    if (!rest.empty()) {
      if (rest.front() != ':') return BadHost(host_header);
      port = rest.substr(1);
      if (!IsPort(port)) return BadHost(host_header);
    }
    return absl::AsciiStrToLower(name);
  }
  if (size_t colon = name.find(':'); colon != name.npos) {
    port = name.substr(colon + 1);
    name = name.substr(0, colon);
    if (!IsPort(port)) return BadHost(host_header);
  }
  if (name.empty() || !absl::c_all_of(name, IsHostChar)) {
    return BadHost(host_header);
  }
  return absl::AsciiStrToLower(name);
}

absl::Status CheckHost(absl::string_view host_header,
                       const std::vector<std::string>& served) {
  absl::StatusOr<std::string> name = HostName(host_header);
  if (!name.ok()) {
    return absl::PermissionDeniedError(name.status().message());
  }
  if (absl::c_linear_search(served, *name)) return absl::OkStatus();
  return absl::PermissionDeniedError(absl::StrCat(
      "hdrstereod is not served under the name ", QuoteInput(*name),
      "; it answers to ", absl::StrJoin(served, ", "),
      " (add the name with http-host in its configuration)"));
}

absl::Status CheckOrigin(absl::string_view origin, absl::string_view scheme,
                         absl::string_view host_header) {
  const std::string own = absl::StrCat(scheme, "://", host_header);
  if (absl::EqualsIgnoreCase(origin, own)) return absl::OkStatus();
  return absl::PermissionDeniedError(
      absl::StrCat("a request from the page of ", QuoteInput(origin),
                   " may not change anything on ", QuoteInput(own),
                   " (cross-site requests are refused)"));
}

std::optional<std::string> CookieValue(absl::string_view cookie_header,
                                       absl::string_view name) {
  for (absl::string_view pair : absl::StrSplit(cookie_header, ';')) {
    pair = absl::StripAsciiWhitespace(pair);
    const size_t equals = pair.find('=');
    if (equals == pair.npos) continue;
    if (absl::StripAsciiWhitespace(pair.substr(0, equals)) != name) continue;
    absl::string_view value =
        absl::StripAsciiWhitespace(pair.substr(equals + 1));
    if (value.size() >= 2 && value.front() == '"' && value.back() == '"') {
      value = value.substr(1, value.size() - 2);
    }
    return std::string(value);
  }
  return std::nullopt;
}

std::optional<ByteRange> ParseRange(absl::string_view header) {
  absl::string_view spec = absl::StripAsciiWhitespace(header);
  if (!absl::ConsumePrefix(&spec, "bytes=")) return std::nullopt;
  spec = absl::StripAsciiWhitespace(spec);
  const size_t dash = spec.find('-');
  if (dash == spec.npos || spec.find(',') != spec.npos) return std::nullopt;
  std::optional<int64_t> first = Offset(spec.substr(0, dash));
  if (!first.has_value()) return std::nullopt;  // a suffix range, or junk
  ByteRange range{*first, std::nullopt};
  absl::string_view last_text = spec.substr(dash + 1);
  if (last_text.empty()) return range;
  std::optional<int64_t> last = Offset(last_text);
  if (!last.has_value() || *last < *first) return std::nullopt;
  range.last = *last;
  return range;
}

absl::StatusOr<ResolvedRange> ResolveRange(const ByteRange& range,
                                           int64_t total) {
  if (range.first >= total) {
    return absl::OutOfRangeError(absl::StrCat("the range starts at byte ",
                                              range.first, " but the file has ",
                                              total, " bytes"));
  }
  const int64_t last =
      range.last.has_value() ? std::min(*range.last, total - 1) : total - 1;
  return ResolvedRange{range.first, last - range.first + 1};
}

absl::StatusOr<std::string> ReportFilePath(absl::string_view name) {
  const bool plain =
      !name.empty() && name.size() <= kMaxReportNameBytes &&
      name.front() != '.' && absl::c_all_of(name, [](char c) {
        return absl::ascii_isalnum(c) || c == '.' || c == '-' || c == '_';
      });
  if (!plain) {
    return absl::NotFoundError(absl::StrCat(
        "no such report file: ", QuoteInput(name),
        " (a report file is named by one plain name of at most ",
        kMaxReportNameBytes,
        " letters, digits, '.', '-' and '_', not starting with '.', as in "
        "/files/sessions/<session>/report/index.html)"));
  }
  return absl::StrCat("report/", name);
}

}  // namespace hdrstereo::http
