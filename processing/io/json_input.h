// SPDX-License-Identifier: GPL-3.0-or-later
//
// JSON received from others (layout, scene and session files), read with
// nlohmann::json:
// - its parse errors quote everything the lexer read of the last token
//   ("last read: '...'", "number overflow parsing '...'"), which for an
//   unterminated string is the rest of the file;
// - it holds a non-negative integer as uint64, which get<int64_t>() wraps
//   (18446744073709551615 reads as -1, inside many a range).
#ifndef HDRSTEREO_PROCESSING_IO_JSON_INPUT_H_
#define HDRSTEREO_PROCESSING_IO_JSON_INPUT_H_

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>

#include "absl/strings/string_view.h"

namespace hdrstereo::io {

// `what` (a nlohmann::json exception's what()) with the text it quotes
// (what it last read, a number too large) quoted through QuoteInput instead;
// other messages are returned unchanged.
std::string BoundedJsonError(absl::string_view what);

// `j` as an int64; nullopt when it is not an integer or one that int64
// does not hold (j.is_number_integer() tells the two apart).
std::optional<int64_t> JsonInt64(const nlohmann::json& j);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_JSON_INPUT_H_
