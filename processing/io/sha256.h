// SPDX-License-Identifier: GPL-3.0-or-later
//
// SHA-256 of bytes and files (lowercase hex), to verify that a stored frame
// or artifact is exactly what was recorded.
#ifndef HDRSTEREO_PROCESSING_IO_SHA256_H_
#define HDRSTEREO_PROCESSING_IO_SHA256_H_

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

std::string Sha256Hex(absl::string_view data);
// NOT_FOUND when the file is missing; streams large files.
absl::StatusOr<std::string> Sha256HexOfFile(const std::filesystem::path& path);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_SHA256_H_
