// SPDX-License-Identifier: GPL-3.0-or-later
//
// What every option struct of processing/ has: a public
// `absl::Status Validate() const` whose INVALID_ARGUMENT names the field
// that broke a rule, and a canonical JSON form (an nlohmann `to_json`
// overload beside the struct). The pipeline's cache key is the canonical
// JSON of the very struct a step runs with, so a changed default or field
// recomputes that step.
//
//   absl::Status GuidedFilterOptions::Validate() const {
//     RETURN_IF_ERROR(RequireField(radius >= 1, "radius", radius, ">= 1"));
//     ...
//   }
//   std::string key = CanonicalJson(options);
//
// A `to_json` binds every field with a structured binding, so adding a field
// to a struct without adding it to its JSON form does not compile.
#ifndef HDRSTEREO_PROCESSING_BASE_OPTIONS_H_
#define HDRSTEREO_PROCESSING_BASE_OPTIONS_H_

#include <nlohmann/json.hpp>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "processing/base/status_macros.h"

namespace hdrstereo {

// OK when `ok`; else INVALID_ARGUMENT "<field> is <value>; it must be
// <rule>" (e.g. "radius is 0; it must be >= 1").
inline absl::Status RequireField(bool ok, absl::string_view field, double value,
                                 absl::string_view rule) {
  if (ok) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrFormat("%s is %g; it must be %s", field, value, rule));
}

// A nested struct's error with its field name in front ("guided." +
// "radius is 0; ...").
inline absl::Status WithFieldPrefix(absl::string_view prefix,
                                    const absl::Status& status) {
  if (status.ok()) return status;
  return absl::Status(status.code(),
                      absl::StrCat(prefix, ".", status.message()));
}

// The canonical JSON text of an option struct: keys sorted, numbers in
// their shortest round-trip form, no white space. Equal structs give equal
// text; any changed field changes it.
template <typename T>
std::string CanonicalJson(const T& options) {
  return nlohmann::json(options).dump();
}

}  // namespace hdrstereo

#endif  // HDRSTEREO_PROCESSING_BASE_OPTIONS_H_
