// SPDX-License-Identifier: GPL-3.0-or-later
//
// Names that become folder names (sessions, schedules) must be safe slugs.
#ifndef HDRSTEREO_DAEMON_STORE_NAMES_H_
#define HDRSTEREO_DAEMON_STORE_NAMES_H_

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::store {

inline constexpr int kMaxNameLength = 64;

// OK for 1-64 characters of [A-Za-z0-9_-] starting with a letter or digit
// (a leading '-' would read as an option on a command line); otherwise
// INVALID_ARGUMENT saying what is wrong. `what` names the thing, e.g.
// "session name".
absl::Status ValidateName(absl::string_view name, absl::string_view what);

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_NAMES_H_
