// SPDX-License-Identifier: GPL-3.0-or-later
//
// The persisted rig lock (table `rig_lock`, at most one row), so that a
// restart keeps it. The rules live in daemon/jobs/rig_lock.h.
#ifndef HDRSTEREO_DAEMON_STORE_RIG_LOCK_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_RIG_LOCK_REPOSITORY_H_

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

struct RigLockRecord {
  std::string holder;
  std::string note;
  int64_t lock_time_ms = 0;
  int64_t expire_time_ms = 0;
};

class RigLockRepository {
 public:
  explicit RigLockRepository(Store& store) : store_(store) {}

  absl::StatusOr<std::optional<RigLockRecord>> Get();
  // Replaces the lock (there is only one).
  absl::Status Put(const RigLockRecord& lock);
  absl::Status Clear();

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_RIG_LOCK_REPOSITORY_H_
