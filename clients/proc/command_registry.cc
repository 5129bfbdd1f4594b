// SPDX-License-Identifier: GPL-3.0-or-later
#include "clients/proc/command_registry.h"

#include <algorithm>
#include <utility>

namespace hdrstereo::proc {
namespace {

std::vector<CommandGroupEntry>& Groups() {
  static auto* groups = new std::vector<CommandGroupEntry>();
  return *groups;
}

absl::Status& Outcome() {
  static auto* outcome = new absl::Status();
  return *outcome;
}

}  // namespace

CommandGroup::CommandGroup(const char* name, AddCommandsFn add) {
  Groups().push_back({name, add});
}

std::vector<CommandGroupEntry> RegisteredGroups() {
  std::vector<CommandGroupEntry> sorted = Groups();
  std::sort(sorted.begin(), sorted.end(),
            [](const auto& a, const auto& b) { return a.name < b.name; });
  return sorted;
}

void SetOutcome(absl::Status status) { Outcome() = std::move(status); }

absl::Status TakeOutcome() {
  return std::exchange(Outcome(), absl::OkStatus());
}

}  // namespace hdrstereo::proc
