// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereo-proc is assembled from command groups, one source file each
// (<group>_command.cc). A group registers itself at static-initialisation
// time and adds its subcommands to the CLI11 app; adding a group means adding
// one file to clients/proc/CMakeLists.txt and nothing else:
//
//   namespace {
//   void AddTonemapCommands(CLI::App& app) {
//     auto* cmd = app.add_subcommand("tonemap", "...");
//     auto opts = std::make_shared<Options>();
//     cmd->add_option("--in", opts->in)->required();
//     cmd->callback([opts] { SetOutcome(RunTonemap(*opts)); });
//   }
//   const CommandGroup kGroup("tonemap", &AddTonemapCommands);
//   }  // namespace
//
// A callback reports its result with SetOutcome(); main prints a failed
// status on stderr and exits with 1.
#ifndef HDRSTEREO_CLIENTS_PROC_COMMAND_REGISTRY_H_
#define HDRSTEREO_CLIENTS_PROC_COMMAND_REGISTRY_H_

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace hdrstereo::proc {

using AddCommandsFn = void (*)(CLI::App& app);

struct CommandGroupEntry {
  std::string name;
  AddCommandsFn add;
};

// Registers a group; define one namespace-scope instance per group file.
class CommandGroup {
 public:
  CommandGroup(const char* name, AddCommandsFn add);
};

// Every registered group, sorted by name (so help output is stable).
std::vector<CommandGroupEntry> RegisteredGroups();

// The outcome of the subcommand that ran (OK if none reported).
void SetOutcome(absl::Status status);
absl::Status TakeOutcome();

}  // namespace hdrstereo::proc

#endif  // HDRSTEREO_CLIENTS_PROC_COMMAND_REGISTRY_H_
