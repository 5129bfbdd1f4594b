// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/rig_lock.h"

#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::jobs {

absl::StatusOr<std::unique_ptr<RigLock>> RigLock::Load(
    store::Store& store, std::function<absl::Time()> clock) {
  ASSIGN_OR_RETURN(std::optional<store::RigLockRecord> record,
                   store::RigLockRepository(store).Get());
  std::optional<RigLockState> state;
  if (record.has_value()) {
    state = RigLockState{
        .holder = record->holder,
        .note = record->note,
        .lock_time = absl::FromUnixMillis(record->lock_time_ms),
        .expire_time = absl::FromUnixMillis(record->expire_time_ms)};
  }
  return std::unique_ptr<RigLock>(
      new RigLock(store, std::move(clock), std::move(state)));
}

std::optional<RigLockState> RigLock::CurrentLocked() {
  if (state_.has_value() && clock_() >= state_->expire_time) state_.reset();
  return state_;
}

std::optional<RigLockState> RigLock::Current() {
  absl::MutexLock lock(&mutex_);
  return CurrentLocked();
}

std::string RigLock::Describe(const RigLockState& state) const {
  const absl::TimeZone zone = absl::LocalTimeZone();
  // The time of day suffices within a day; later expiries name the date.
  const char* format = state.expire_time - clock_() < absl::Hours(20)
                           ? "%H:%M"
                           : "%Y-%m-%d %H:%M";
  return absl::StrCat("locked by ", state.holder, " until ",
                      absl::FormatTime(format, state.expire_time, zone),
                      state.note.empty() ? "" : ": ", state.note);
}

absl::StatusOr<RigLockState> RigLock::Acquire(absl::string_view holder,
                                              absl::string_view note,
                                              absl::Duration ttl) {
  if (ttl <= absl::ZeroDuration() || ttl > kMaxRigLockTtl) {
    return absl::InvalidArgumentError(
        absl::StrCat("ttl_s is ", absl::ToInt64Seconds(ttl),
                     "; a lock lasts 1 s to 7 days (604800 s)"));
  }
  if (note.size() > kMaxRigLockNoteBytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        "note has ", note.size(), " bytes; at most ", kMaxRigLockNoteBytes));
  }
  absl::MutexLock lock(&mutex_);
  if (std::optional<RigLockState> current = CurrentLocked();
      current.has_value() && current->holder != holder) {
    return absl::FailedPreconditionError(Describe(*current));
  }
  const absl::Time now = clock_();
  RigLockState next{.holder = std::string(holder),
                    .note = std::string(note),
                    .lock_time = now,
                    .expire_time = now + ttl};
  RETURN_IF_ERROR(repository_.Put(
      {.holder = next.holder,
       .note = next.note,
       .lock_time_ms = absl::ToUnixMillis(next.lock_time),
       .expire_time_ms = absl::ToUnixMillis(next.expire_time)}));
  state_ = next;
  return next;
}

absl::StatusOr<RigLockState> RigLock::Release(absl::string_view principal,
                                              bool force) {
  absl::MutexLock lock(&mutex_);
  std::optional<RigLockState> current = CurrentLocked();
  if (!current.has_value()) {
    return absl::FailedPreconditionError("the rig is not locked");
  }
  if (current->holder != principal && !force) {
    return absl::FailedPreconditionError(absl::StrCat(
        "the rig is ", Describe(*current), "; only ", current->holder,
        " can unlock it, or an admin with force"));
  }
  RETURN_IF_ERROR(repository_.Clear());
  state_.reset();
  return *current;
}

absl::Status RigLock::CheckFor(absl::string_view principal) {
  absl::MutexLock lock(&mutex_);
  std::optional<RigLockState> current = CurrentLocked();
  if (!current.has_value() || current->holder == principal) {
    return absl::OkStatus();
  }
  return absl::FailedPreconditionError(Describe(*current));
}

absl::Status RigLock::CheckUnattended() {
  absl::MutexLock lock(&mutex_);
  std::optional<RigLockState> current = CurrentLocked();
  if (!current.has_value()) return absl::OkStatus();
  return absl::FailedPreconditionError(Describe(*current));
}

}  // namespace hdrstereo::jobs
