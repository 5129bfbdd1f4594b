// SPDX-License-Identifier: GPL-3.0-or-later
//
// Sessions: rows in `sessions` plus a folder under <data-root>/sessions/.
#ifndef HDRSTEREO_DAEMON_STORE_SESSION_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_SESSION_REPOSITORY_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

inline constexpr int kMaxNoteBytes = 4096;

struct SessionRecord {
  int64_t id = 0;
  std::string name;
  std::string note;
  int64_t create_time_ms = 0;
  int capture_count = 0;
  int frame_count = 0;
  int artifact_count = 0;
};

struct SessionPage {
  std::vector<SessionRecord> sessions;
  std::string next_after;  // name to continue after; empty on the last page
};

struct DeletedSession {
  int frames = 0;
  int artifacts = 0;
};

class SessionRepository {
 public:
  explicit SessionRepository(Store& store) : store_(store) {}

  // INVALID_ARGUMENT for a bad name or note, ALREADY_EXISTS for a taken name.
  absl::StatusOr<SessionRecord> Create(absl::string_view name,
                                       absl::string_view note);
  // NOT_FOUND when there is no such session.
  absl::StatusOr<SessionRecord> Get(absl::string_view name);
  // Sessions ordered by name, starting after `after` (empty = from the start).
  absl::StatusOr<SessionPage> List(absl::string_view after, int limit);
  // Removes the rows (frames, artifacts, ... cascade) and then the folder.
  // FAILED_PRECONDITION while a job of the session is queued, running or
  // paused.
  absl::StatusOr<DeletedSession> Delete(absl::string_view name);

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_SESSION_REPOSITORY_H_
