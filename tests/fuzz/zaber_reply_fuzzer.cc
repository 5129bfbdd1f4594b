// SPDX-License-Identifier: GPL-3.0-or-later
// Replies of a Zaber stage controller on the serial line.
#include <string>

#include "hardware/zaber/protocol.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  absl::StatusOr<hdrstereo::zaber::Reply> reply =
      hdrstereo::zaber::ParseReply(hdrstereo::fuzz::AsText(data, size));
  if (!reply.ok()) return 0;
  for (const std::string& flag :
       hdrstereo::zaber::ParseWarningFlags(reply->data)) {
    FUZZ_CHECK(!hdrstereo::zaber::DescribeWarning(flag).empty());
    (void)hdrstereo::zaber::IsFault(flag);
  }
  if (!reply->warning.empty()) {
    FUZZ_CHECK(!hdrstereo::zaber::DescribeWarning(reply->warning).empty());
  }
  return 0;
}
