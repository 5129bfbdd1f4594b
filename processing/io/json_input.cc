// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/json_input.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"

namespace hdrstereo::io {

std::string BoundedJsonError(absl::string_view what) {
  // "<message>; last read: '<token>'[; expected <tokens>]" and
  // "<message> number overflow parsing '<token>'".
  constexpr absl::string_view kStarts[] = {"; last read: '", " parsing '"};
  constexpr absl::string_view kExpected = "'; expected ";
  for (const absl::string_view start : kStarts) {
    const size_t quote = what.find(start);
    if (quote == absl::string_view::npos) continue;
    const size_t token = quote + start.size();
    size_t end = what.rfind(kExpected);
    if (end == absl::string_view::npos || end < token) {
      end = what.size();
      if (end > token && what.back() == '\'') --end;
    }
    return absl::StrCat(what.substr(0, token - 1),
                        QuoteInput(what.substr(token, end - token)),
                        what.substr(std::min(end + 1, what.size())));
  }
  return std::string(what);
}

std::optional<int64_t> JsonInt64(const nlohmann::json& j) {
  if (!j.is_number_integer() ||
      (j.is_number_unsigned() && j.get<uint64_t>() > uint64_t{INT64_MAX})) {
    return std::nullopt;
  }
  return j.get<int64_t>();
}

}  // namespace hdrstereo::io
