// SPDX-License-Identifier: GPL-3.0-or-later
//
// Checks of an HTTP request's headers that decide whether the edge serves
// it at all, as pure functions on the received text: the Host a request
// names (against DNS rebinding), its Origin (against cross-site requests),
// the session cookie, a download's Range, and a report file's name.
#ifndef HDRSTEREO_DAEMON_HTTP_REQUEST_CHECKS_H_
#define HDRSTEREO_DAEMON_HTTP_REQUEST_CHECKS_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::http {

// The host name of a Host header ("lab-pc:8443" -> "lab-pc", "[::1]:80" ->
// "[::1]"), lower-cased; INVALID_ARGUMENT for an empty or malformed one
// (characters outside those of DNS names and IP literals, a bad port).
absl::StatusOr<std::string> HostName(absl::string_view host_header);

// OK when the Host header names one of `served` (lower-case names: those in
// the configuration, and the listen addresses' own); else PERMISSION_DENIED
// saying which names are served. A page on another name that resolves to
// this machine (DNS rebinding) is refused here.
absl::Status CheckHost(absl::string_view host_header,
                       const std::vector<std::string>& served);

// OK when `origin` is the request's own origin: `scheme` ("http" or
// "https") + "://" + the Host header, compared without regard to case.
// PERMISSION_DENIED otherwise, naming both.
absl::Status CheckOrigin(absl::string_view origin, absl::string_view scheme,
                         absl::string_view host_header);

// The value of cookie `name` in a Cookie header; nullopt when absent.
std::optional<std::string> CookieValue(absl::string_view cookie_header,
                                       absl::string_view name);

// A single byte range "bytes=FIRST-[LAST]". nullopt when the header asks
// for something else (several ranges, a suffix range, another unit): the
// whole file is sent then, as RFC 9110 allows.
struct ByteRange {
  int64_t first = 0;
  std::optional<int64_t> last;  // inclusive; nullopt = to the end
};
std::optional<ByteRange> ParseRange(absl::string_view header);
// The range within a file of `total` bytes as [offset, offset + length):
// OUT_OF_RANGE when it starts at or beyond the end (HTTP 416).
struct ResolvedRange {
  int64_t offset = 0;
  int64_t length = 0;
};
absl::StatusOr<ResolvedRange> ResolveRange(const ByteRange& range,
                                           int64_t total);

// The artifact path ("report/<name>") of a report file named in a URL
// (/files/sessions/<session>/report/<name>, `name` as written: no
// percent-decoding). A name is one plain path component: 1 to 128 letters,
// digits, '.', '-' and '_', not starting with '.' (so never "." or "..",
// and never '/', '\' or NUL). NOT_FOUND otherwise, saying what a name
// may be.
absl::StatusOr<std::string> ReportFilePath(absl::string_view name);

}  // namespace hdrstereo::http

#endif  // HDRSTEREO_DAEMON_HTTP_REQUEST_CHECKS_H_
