// SPDX-License-Identifier: GPL-3.0-or-later
//
// Validation and encoding of PageRequest (hdrstereo/v1/common.proto).
#ifndef HDRSTEREO_DAEMON_RPC_PAGINATION_H_
#define HDRSTEREO_DAEMON_RPC_PAGINATION_H_

#include <string>

#include "absl/status/statusor.h"
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

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_PAGINATION_H_
