// SPDX-License-Identifier: GPL-3.0-or-later
// The daemon's TOML config file (hdrstereod --config).
#include "daemon/config.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  (void)hdrstereo::daemon::ParseConfigText(hdrstereo::fuzz::AsText(data, size));
  return 0;
}
