// SPDX-License-Identifier: GPL-3.0-or-later
// `gphoto2 --summary` / `--list-all-config` dumps that the replayed camera
// and the settings logic read.
#include <string>

#include "hardware/gphoto2/config_dump.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const absl::string_view text = hdrstereo::fuzz::AsText(data, size);
  // Replacing invalid UTF-8 leaves nothing to replace.
  const std::string valid = hdrstereo::gphoto2::ValidUtf8(text);
  FUZZ_CHECK(hdrstereo::gphoto2::ValidUtf8(valid) == valid);
  absl::StatusOr<hdrstereo::gphoto2::CameraDump> dump =
      hdrstereo::gphoto2::ParseCameraDump(text, "fuzz");
  if (!dump.ok()) return 0;
  FUZZ_CHECK(!dump->widgets.empty());
  return 0;
}
