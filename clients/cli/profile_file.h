// SPDX-License-Identifier: GPL-3.0-or-later
//
// The CLI's profile file, ~/.config/hdrstereo/client.toml (the Python client
// reads the same file; connection.h says how profiles are chosen):
//
//   default_profile = "lab"            # optional
//   [profile.lab]
//   server = "labpc.example.org:50051"
//   tls_ca = "lab-ca.pem"              # relative paths: to this file's folder
//   tls_cert = "alice.pem"             # client certificate (PEM)
//   tls_key = "alice.key"              # its key (PEM, mode 0600)
//   api_key_file = "notebook.key"      # instead of cert and key (mode 0600)
//
// A fixed subset of TOML: [profile.NAME] sections of "quoted string" values
// (\" and \\ escapes), # comments. Unknown keys and sections are refused by
// name.
#ifndef HDRSTEREO_CLIENTS_CLI_PROFILE_FILE_H_
#define HDRSTEREO_CLIENTS_CLI_PROFILE_FILE_H_

#include <cstddef>
#include <filesystem>
#include <map>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::cli {

// Limits on a profile file (it may be a copy from elsewhere): its size, and
// a line's length (a PATH_MAX path, escaped, with its key).
inline constexpr size_t kMaxProfileFileBytes = size_t{1} << 20;
inline constexpr size_t kMaxProfileLineBytes = 8192;

// The connection settings of one profile, paths as written in the file.
struct Profile {
  std::string server;
  std::string tls_ca;
  std::string tls_cert;
  std::string tls_key;
  std::string api_key_file;
};

struct ProfileFile {
  std::string default_profile;
  std::map<std::string, Profile> profiles;
};

// Parses the text of a client.toml; INVALID_ARGUMENT naming `path`, the
// line and the offending key or section, or the limit a text or a line
// exceeds. Received text is quoted bounded (QuoteInput).
absl::StatusOr<ProfileFile> ParseProfileFile(const std::string& path,
                                             absl::string_view text);

// Reads and parses the file at `path` (INVALID_ARGUMENT when it cannot be
// read or is larger than kMaxProfileFileBytes, refused by its size before
// it is read).
absl::StatusOr<ProfileFile> LoadProfileFile(const std::filesystem::path& path);

}  // namespace hdrstereo::cli

#endif  // HDRSTEREO_CLIENTS_CLI_PROFILE_FILE_H_
