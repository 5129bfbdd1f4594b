// SPDX-License-Identifier: GPL-3.0-or-later
//
// JSON received from others (layout, scene and session files), read with
// nlohmann::json:
// - its parse errors quote everything the lexer read of the last token
//   ("last read: '...'", "number overflow parsing '...'"), which for an
//   unterminated string is the rest of the file;
// - it holds a non-negative integer as uint64, which get<int64_t>() wraps
//   (18446744073709551615 reads as -1, inside many a range).
//
//   try { j = nlohmann::json::parse(text); }
//   catch (const nlohmann::json::exception& e) {
//     return absl::InvalidArgumentError(BoundedJsonError(e.what()));
//   }
//   ASSIGN_OR_RETURN(int64_t bits, JsonIntInRange(j["bits"], "bits", 1, 16));
#ifndef HDRSTEREO_PROCESSING_IO_JSON_INPUT_H_
#define HDRSTEREO_PROCESSING_IO_JSON_INPUT_H_

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

// `what` (a nlohmann::json exception's what()) with the text it quotes
// (what it last read, a number too large) quoted through QuoteInput instead;
// other messages are returned unchanged.
std::string BoundedJsonError(absl::string_view what);

// `j` as an int64; nullopt when it is not an integer or one that int64
// does not hold (j.is_number_integer() tells the two apart).
std::optional<int64_t> JsonInt64(const nlohmann::json& j);

// `j` (the value of `field`, e.g. "columns.bits") as an integer in
// [min, max]: INVALID_ARGUMENT "<field>: expected an integer" or
// "<field>: <value> is outside [<min>, <max>]" (CheckRange's wording; a
// value beyond int64 too, never wrapped into the range).
absl::StatusOr<int64_t> JsonIntInRange(const nlohmann::json& j,
                                       absl::string_view field, int64_t min,
                                       int64_t max);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_JSON_INPUT_H_
