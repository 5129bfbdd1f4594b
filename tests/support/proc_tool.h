// SPDX-License-Identifier: GPL-3.0-or-later
//
// Runs the hdrstereo-proc executable (its path comes from the test target's
// HDRSTEREO_PROC definition) with a bounded wait.
#ifndef HDRSTEREO_TESTS_SUPPORT_PROC_TOOL_H_
#define HDRSTEREO_TESTS_SUPPORT_PROC_TOOL_H_

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tests/support/subprocess.h"

namespace hdrstereo::testing {

inline CommandResult Proc(std::vector<std::string> args,
                          absl::Duration timeout = absl::Seconds(300)) {
  args.insert(args.begin(), HDRSTEREO_PROC);
  absl::StatusOr<CommandResult> result = RunCommand(args, timeout);
  EXPECT_TRUE(result.ok()) << result.status();
  return result.ok() ? *result : CommandResult{};
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_PROC_TOOL_H_
