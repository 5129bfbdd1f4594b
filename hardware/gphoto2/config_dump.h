// SPDX-License-Identifier: GPL-3.0-or-later
//
// Reads the text `gphoto2 --summary --list-all-config` prints: the summary
// (manufacturer, model) and the configuration tree, one entry per leaf:
//
//   /main/capturesettings/shutterspeed
//   Label: Belichtungszeit
//   Readonly: 0                      (newer gphoto2 only)
//   Type: RADIO                      (RADIO MENU RANGE TEXT TOGGLE DATE)
//   Current: 0,0400s                 (may be "(null)")
//   Choice: 0 0,0002s                (RADIO, MENU)
//   Bottom: 0 / Top: 655,35 / Step: 0,01      (RANGE)
//   Printable: ... / Help: ...       (DATE)
//   END                              (some versions)
//
// Dumps come from many gphoto2 versions and locales: fields may be indented
// with a tab (older versions), labels may be German,
// numbers may use a decimal comma, lines may end in CRLF and text may not be
// valid UTF-8 (such bytes become U+FFFD, so that every string can cross the
// RPC edge). Lines outside entries (the summary, debug output) are skipped.
// A file holding two dumps of one camera (e.g. a German and an English run)
// gives the first entry of each path.
#ifndef HDRSTEREO_HARDWARE_GPHOTO2_CONFIG_DUMP_H_
#define HDRSTEREO_HARDWARE_GPHOTO2_CONFIG_DUMP_H_

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "hardware/gphoto2/gphoto2_api.h"

namespace hdrstereo::gphoto2 {

// Limits on what a dump may hold (it is a file from elsewhere); the real
// dumps stay far below them (the largest is 0.8 MB, 415 entries, a widget of
// 1122 choices, a line of 9 KB, a path of 127 bytes).
inline constexpr size_t kMaxDumpBytes = size_t{16} << 20;
inline constexpr size_t kMaxDumpLineBytes = size_t{64} << 10;
inline constexpr int64_t kMaxDumpEntries = 8192;  // /main/... paths
inline constexpr size_t kMaxWidgetPathBytes = 256;
// A PTP enumeration's count is 16 bits.
inline constexpr int64_t kMaxWidgetChoices = 65535;

struct CameraDump {
  std::string source;  // the file (or name) it was read from, for messages
  // "Nikon Corporation D750" from the summary's Manufacturer/Model lines
  // (or Hersteller/Modell), else the cameramodel widget, else `source`'s stem.
  std::string model;
  std::string summary;                // the text before the config tree
  std::vector<ConfigWidget> widgets;  // the tree's leaves, in dump order
  // Paths listed without a Type (a `--list-config` listing or a truncated
  // entry): not replayed. "path (line N)".
  std::vector<std::string> skipped;
};

// INVALID_ARGUMENT naming the line and the entry for an unknown Type, a
// RANGE without finite numeric Bottom/Top/Step, a malformed Choice line, or
// a text, line, path or count beyond the limits above (naming the limit); a
// text without any complete config entry is an error too ("no
// --list-all-config tree"). Entries without a Type are skipped
// (CameraDump::skipped). Received text is quoted bounded (QuoteInput).
absl::StatusOr<CameraDump> ParseCameraDump(absl::string_view text,
                                           absl::string_view source);

// Reads and parses a dump file (NOT_FOUND when it does not exist,
// INVALID_ARGUMENT when it is larger than kMaxDumpBytes, refused by its size
// before it is read).
absl::StatusOr<CameraDump> LoadCameraDump(const std::filesystem::path& path);

// `text` with every invalid UTF-8 sequence replaced by U+FFFD.
std::string ValidUtf8(absl::string_view text);

}  // namespace hdrstereo::gphoto2

#endif  // HDRSTEREO_HARDWARE_GPHOTO2_CONFIG_DUMP_H_
