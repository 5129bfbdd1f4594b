// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/pagination.h"

#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::rpc {
namespace {
constexpr absl::string_view kTokenPrefix = "after:";
constexpr absl::string_view kNotIssued =
    "page.page_token was not issued by this server; pass the "
    "next_page_token of the previous response";
}  // namespace

absl::StatusOr<Page> ParsePage(const v1::PageRequest& request) {
  Page page;
  if (request.page_size() < 0 || request.page_size() > kMaxPageSize) {
    return absl::InvalidArgumentError(absl::StrCat(
        "page.page_size is ", request.page_size(), "; use 0 (default ",
        kDefaultPageSize, ") to ", kMaxPageSize));
  }
  if (request.page_size() > 0) page.size = request.page_size();
  if (!request.page_token().empty()) {
    std::string decoded;
    if (!absl::WebSafeBase64Unescape(request.page_token(), &decoded) ||
        !absl::StartsWith(decoded, kTokenPrefix)) {
      return absl::InvalidArgumentError(kNotIssued);
    }
    page.after = decoded.substr(kTokenPrefix.size());
  }
  return page;
}

absl::StatusOr<IdPage> ParseIdPage(const v1::PageRequest& request) {
  ASSIGN_OR_RETURN(Page page, ParsePage(request));
  IdPage id_page{.size = page.size};
  if (!page.after.empty() &&
      (!absl::SimpleAtoi(page.after, &id_page.after) || id_page.after <= 0)) {
    return absl::InvalidArgumentError(kNotIssued);
  }
  return id_page;
}

std::string EncodePageToken(const std::string& after) {
  if (after.empty()) return "";
  return absl::WebSafeBase64Escape(absl::StrCat(kTokenPrefix, after));
}

}  // namespace hdrstereo::rpc
