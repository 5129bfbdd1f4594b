// SPDX-License-Identifier: GPL-3.0-or-later
//
// Paths named relative to a folder by something that does not own it (the
// daemon's own writers, a cluster node's result and pipeline state files, a
// job request read on the node): checked before they are joined to the
// folder, so that no name reaches outside it.
#ifndef HDRSTEREO_PROCESSING_IO_RELATIVE_PATH_H_
#define HDRSTEREO_PROCESSING_IO_RELATIVE_PATH_H_

#include <cstddef>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

// The longest path Linux opens (PATH_MAX).
inline constexpr size_t kMaxRelativePathBytes = 4096;

// INVALID_ARGUMENT quoting (a bounded prefix of) `path` unless it is
// non-empty, at most kMaxRelativePathBytes long, not absolute, free of NUL
// bytes, and made of '/'-separated components none of which is empty, "."
// or "..".
absl::Status ValidateRelativePath(absl::string_view path);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_RELATIVE_PATH_H_
