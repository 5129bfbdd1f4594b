// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/json_input.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"

namespace hdrstereo::io {

namespace {

// nlohmann::json's names of the tokens a parse error says it expected
// (lexer::token_type_name), as in "; expected end of input".
constexpr absl::string_view kTokenNames[] = {"<uninitialized>",
                                             "true literal",
                                             "false literal",
                                             "null literal",
                                             "string literal",
                                             "number literal",
                                             "'['",
                                             "'{'",
                                             "']'",
                                             "'}'",
                                             "':'",
                                             "','",
                                             "<parse error>",
                                             "end of input",
                                             "'[', '{', or a literal",
                                             "unknown token"};

// Where the token that starts at `token` in `what` ends: before its closing
// quote, which is followed by nothing or by "; expected <token name>". The
// token is received text and may hold "'; expected " itself, so only the
// short tails that nlohmann writes are recognised; anything else is taken
// to be part of the token, and quoted with it.
size_t TokenEnd(absl::string_view what, size_t token) {
  for (const absl::string_view name : kTokenNames) {
    const std::string tail = absl::StrCat("'; expected ", name);
    if (what.size() >= token + tail.size() && absl::EndsWith(what, tail)) {
      return what.size() - tail.size();
    }
  }
  if (what.size() > token && what.back() == '\'') return what.size() - 1;
  return what.size();
}

}  // namespace

std::string BoundedJsonError(absl::string_view what) {
  // "<message>; last read: '<token>'[; expected <token name>]" and
  // "<message> number overflow parsing '<token>'".
  constexpr absl::string_view kStarts[] = {"; last read: '", " parsing '"};
  for (const absl::string_view start : kStarts) {
    const size_t quote = what.find(start);
    if (quote == absl::string_view::npos) continue;
    const size_t token = quote + start.size();
    const size_t end = TokenEnd(what, token);
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

absl::StatusOr<int64_t> JsonIntInRange(const nlohmann::json& j,
                                       absl::string_view field, int64_t min,
                                       int64_t max) {
  if (!j.is_number_integer()) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": expected an integer"));
  }
  const std::optional<int64_t> v = JsonInt64(j);
  if (!v.has_value()) {
    // Beyond int64, so at most 20 digits: dump() is bounded.
    return absl::InvalidArgumentError(absl::StrCat(
        field, ": ", j.dump(), " is outside [", min, ", ", max, "]"));
  }
  if (absl::Status s = CheckRange(field, *v, min, max); !s.ok()) return s;
  return *v;
}

}  // namespace hdrstereo::io
