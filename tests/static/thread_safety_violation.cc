// SPDX-License-Identifier: GPL-3.0-or-later
//
// Must NOT compile under deploy/check-thread-safety.sh: it prepares a
// statement without holding the connection's lock. The script checks that
// clang rejects it, so a build where the analysis silently does nothing
// (annotations compiled out, a flag lost) fails instead of passing.
#include "daemon/store/database.h"

namespace hdrstereo::store {

absl::Status PrepareWithoutTheLock(Database& db) {
  return db.Prepare("SELECT 1").status();
}

}  // namespace hdrstereo::store
