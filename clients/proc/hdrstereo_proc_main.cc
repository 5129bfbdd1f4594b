// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc: offline processing of exposure stacks and calibration
// captures, for researchers working on their own data. Subcommands come from
// the command groups in this folder (see command_registry.h).
#include <CLI/CLI.hpp>
#include <iostream>

#include "clients/proc/command_registry.h"
#include "hdrstereo_version.h"
#include "processing/pipeline/memory_estimate.h"

int main(int argc, char** argv) {
  hdrstereo::pipeline::ReturnFreedImagesToTheSystem();
  CLI::App app{"hdrstereo-proc: offline HDR stereo processing"};
  app.set_version_flag("--version", HDRSTEREO_VERSION);
  app.require_subcommand(1);
  for (const auto& group : hdrstereo::proc::RegisteredGroups()) {
    group.add(app);
  }
  CLI11_PARSE(app, argc, argv);
  absl::Status outcome = hdrstereo::proc::TakeOutcome();
  if (!outcome.ok()) {
    std::cerr << "hdrstereo-proc: " << outcome.message() << "\n";
    return 1;
  }
  return 0;
}
