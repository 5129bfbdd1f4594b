// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/names.h"

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::store {

absl::Status ValidateName(absl::string_view name, absl::string_view what) {
  if (name.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(what, " is empty"));
  }
  if (name.size() > kMaxNameLength) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " has ", name.size(), " characters; at most ",
                     kMaxNameLength, " are allowed"));
  }
  if (!absl::ascii_isalnum(static_cast<unsigned char>(name[0]))) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, " \"", name, "\" must start with a letter or digit"));
  }
  for (char c : name) {
    if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '-' &&
        c != '_') {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s \"%s\" contains %s; use only letters, digits, '-' and '_'", what,
          absl::CHexEscape(name),
          absl::ascii_isprint(static_cast<unsigned char>(c))
              ? absl::StrCat("'", std::string(1, c), "'")
              : absl::StrFormat("byte 0x%02x", static_cast<unsigned char>(c))));
    }
  }
  return absl::OkStatus();
}

}  // namespace hdrstereo::store
