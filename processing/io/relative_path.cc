// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/relative_path.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "processing/base/input_limits.h"

namespace hdrstereo::io {

absl::Status ValidateRelativePath(absl::string_view path) {
  auto bad = [&](absl::string_view why) {
    return absl::InvalidArgumentError(
        absl::StrCat("path ", QuoteInput(path), " ", why));
  };
  if (path.empty()) return bad("is empty");
  if (path.size() > kMaxRelativePathBytes) {
    return bad(absl::StrCat("is longer than the limit of ",
                            kMaxRelativePathBytes, " bytes"));
  }
  if (path.front() == '/') return bad("is absolute (it must be relative)");
  if (path.find('\0') != absl::string_view::npos) return bad("has a NUL byte");
  for (absl::string_view part : absl::StrSplit(path, '/')) {
    if (part.empty()) return bad("has an empty component");
    if (part == "." || part == "..") {
      return bad(absl::StrCat("has a \"", part, "\" component"));
    }
  }
  return absl::OkStatus();
}

}  // namespace hdrstereo::io
