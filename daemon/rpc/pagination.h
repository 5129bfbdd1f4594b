// SPDX-License-Identifier: GPL-3.0-or-later
//
// Validation and encoding of PageRequest (hdrstereo/v1/common.proto).
#ifndef HDRSTEREO_DAEMON_RPC_PAGINATION_H_
#define HDRSTEREO_DAEMON_RPC_PAGINATION_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "hdrstereo/v1/common.pb.h"

namespace hdrstereo::rpc {

inline constexpr int kDefaultPageSize = 100;
inline constexpr int kMaxPageSize = 1000;

struct Page {
  int size = kDefaultPageSize;
  std::string after;  // decoded position; empty = first page
};

// INVALID_ARGUMENT for a negative or too large size or a token this server
// did not issue.
absl::StatusOr<Page> ParsePage(const v1::PageRequest& request);
// The opaque token for a page that continues after `after` ("" stays "").
std::string EncodePageToken(const std::string& after);

// A page of rows ordered by an integer key (a row id, a due time), ascending
// or descending: `after` is the key of the previous page's last row, 0 on
// the first page (issued keys are positive).
struct IdPage {
  int size = kDefaultPageSize;
  int64_t after = 0;
};

// ParsePage, and INVALID_ARGUMENT for a token that holds no positive key.
absl::StatusOr<IdPage> ParseIdPage(const v1::PageRequest& request);

// Call with the rows fetched with limit page.size + 1: drops the extra row
// and returns the next_page_token, "" on the last page.
template <typename Row, typename KeyOf>
std::string FinishIdPage(const IdPage& page, std::vector<Row>& rows,
                         KeyOf key_of) {
  if (static_cast<int>(rows.size()) <= page.size) return "";
  rows.erase(rows.begin() + page.size, rows.end());
  return EncodePageToken(absl::StrCat(key_of(rows.back())));
}

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_PAGINATION_H_
