// SPDX-License-Identifier: GPL-3.0-or-later
//
// The rig lock (bluesky-queueserver's `lock`, SiLA's LockController): the
// person at the rig keeps other principals off the hardware for a while.
// While it is held, capture submissions and hardware moves by anyone else
// are refused and due schedules are skipped, with the holder, the expiry
// and the note in the reason. It is a courtesy between people who already
// have access, not access control: roles are that. It is persisted (a
// restart keeps it) and expires at its ttl.
#ifndef HDRSTEREO_DAEMON_JOBS_RIG_LOCK_H_
#define HDRSTEREO_DAEMON_JOBS_RIG_LOCK_H_

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "daemon/store/rig_lock_repository.h"

namespace hdrstereo::jobs {

inline constexpr absl::Duration kMaxRigLockTtl = absl::Hours(24 * 7);
inline constexpr size_t kMaxRigLockNoteBytes = 1024;

struct RigLockState {
  std::string holder;
  std::string note;
  absl::Time lock_time;
  absl::Time expire_time;
};

class RigLock {
 public:
  // Reads the persisted lock. `clock` is injectable for tests.
  static absl::StatusOr<std::unique_ptr<RigLock>> Load(
      store::Store& store,
      std::function<absl::Time()> clock = [] { return absl::Now(); });

  // The lock if it is held and not expired.
  std::optional<RigLockState> Current();

  // Takes the lock for `holder`, or renews `holder`'s own lock with a new
  // note and ttl. INVALID_ARGUMENT for a ttl outside (0, 7 days] or a note
  // over 1 KiB; FAILED_PRECONDITION while another principal holds it.
  absl::StatusOr<RigLockState> Acquire(absl::string_view holder,
                                       absl::string_view note,
                                       absl::Duration ttl);
  // Releases the lock. Only its holder may, unless `force` (the caller has
  // checked that the principal may force). FAILED_PRECONDITION when nobody
  // holds it, or another principal does and `force` is false. Returns the
  // lock as it was.
  absl::StatusOr<RigLockState> Release(absl::string_view principal, bool force);

  // OK unless a principal other than `principal` holds the lock; then
  // FAILED_PRECONDITION "locked by bob until 14:05: re-aligning ...".
  absl::Status CheckFor(absl::string_view principal);
  // OK unless anyone holds the lock (for unattended runs).
  absl::Status CheckUnattended();

 private:
  RigLock(store::Store& store, std::function<absl::Time()> clock,
          std::optional<RigLockState> state)
      : repository_(store),
        clock_(std::move(clock)),
        state_(std::move(state)) {}

  std::optional<RigLockState> CurrentLocked()
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  std::string Describe(const RigLockState& state) const;

  store::RigLockRepository repository_;
  std::function<absl::Time()> clock_;
  absl::Mutex mutex_;
  std::optional<RigLockState> state_ ABSL_GUARDED_BY(mutex_);
};

}  // namespace hdrstereo::jobs

#endif  // HDRSTEREO_DAEMON_JOBS_RIG_LOCK_H_
