// SPDX-License-Identifier: GPL-3.0-or-later
//
// Each group of subcommands registers itself on the root app. Callbacks run
// after parsing, connect with the parsed global options and store their exit
// code in *exit_code.
#ifndef HDRSTEREO_CLIENTS_CLI_COMMANDS_H_
#define HDRSTEREO_CLIENTS_CLI_COMMANDS_H_

#include <CLI/CLI.hpp>

#include "clients/cli/client.h"
#include "hdrstereo/v1/jobs.pb.h"

namespace hdrstereo::cli {

void AddServerCommands(CLI::App& app, const GlobalOptions& options,
                       int* exit_code);
void AddHardwareCommands(CLI::App& app, const GlobalOptions& options,
                         int* exit_code);
// `hw preview` on `hw`, `probe` on `hw projector` (rig_commands.cc).
void AddRigCommands(CLI::App& hw, CLI::App& projector,
                    const GlobalOptions& options, int* exit_code);
void AddJobCommands(CLI::App& app, const GlobalOptions& options,
                    int* exit_code);
void AddScheduleCommands(CLI::App& app, const GlobalOptions& options,
                         int* exit_code);
void AddProcessingCommands(CLI::App& app, const GlobalOptions& options,
                           int* exit_code);
void AddSessionCommands(CLI::App& app, const GlobalOptions& options,
                        int* exit_code);
void AddAdminCommands(CLI::App& app, const GlobalOptions& options,
                      int* exit_code);

// Follows a job's events until it ends (a progress bar on a terminal, one
// line per event otherwise); the exit code says how it ended.
int WatchJob(const Client& client, int64_t job_id);

// "running", "succeeded", ...
std::string StateName(v1::JobState state);
// Succeeded, failed or cancelled: the job will not change any more.
bool IsFinal(v1::JobState state);

}  // namespace hdrstereo::cli

#endif  // HDRSTEREO_CLIENTS_CLI_COMMANDS_H_
