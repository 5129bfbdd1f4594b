// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereod's configuration: command-line flags, optionally read from a
// TOML/INI config file (--config); flags given on the command line win.
#ifndef HDRSTEREO_DAEMON_CONFIG_H_
#define HDRSTEREO_DAEMON_CONFIG_H_

#include <filesystem>
#include <string>
#include <variant>

#include "absl/status/statusor.h"

namespace hdrstereo::daemon {

struct Config {
  std::string listen = "127.0.0.1:50051";
  std::filesystem::path data_root = "data";
  std::string hardware = "sim";    // "sim" or "real"
  std::filesystem::path log_file;  // empty = <data_root>/logs/hdrstereod.log
  std::string log_level = "info";
  // Written (atomically) with the bound address once the server is serving;
  // lets scripts and tests use --listen 127.0.0.1:0.
  std::filesystem::path ready_file;
};

// The result of parsing: a config to run with, or a text (help, version) to
// print before exiting successfully.
struct ExitWithText {
  std::string text;
};
using ParsedArgs = std::variant<Config, ExitWithText>;

// INVALID_ARGUMENT with a one-line message for unknown flags, unknown config
// keys, bad values, or a listen address that is not local.
absl::StatusOr<ParsedArgs> ParseArgs(int argc, const char* const* argv);

// OK for "unix:PATH" and loopback host:port; remote listening needs TLS,
// which hdrstereod does not offer yet.
absl::Status ValidateListenAddress(const std::string& address);

}  // namespace hdrstereo::daemon

#endif  // HDRSTEREO_DAEMON_CONFIG_H_
