// SPDX-License-Identifier: GPL-3.0-or-later
// The CLI's client.toml connection profiles.
#include "clients/cli/profile_file.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  (void)hdrstereo::cli::ParseProfileFile("client.toml",
                                         hdrstereo::fuzz::AsText(data, size));
  return 0;
}
