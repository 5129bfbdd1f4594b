// SPDX-License-Identifier: GPL-3.0-or-later
//
// The files of the data root:
//   <data-root>/hdrstereo.db         SQLite database (WAL)
//   <data-root>/sessions/<name>/     one folder per session (Middlebury-style)
//   <data-root>/sessions/<name>/jobs/<id>/  a processing job run elsewhere
//                                    (a Slurm batch job): request, result, log
//   <data-root>/trash/               folders of deleted sessions, being removed
//   <data-root>/orphaned/<name>-<t>/ folders found without a database row
//                                    (e.g. after a crash); kept for a person
#ifndef HDRSTEREO_DAEMON_STORE_FILE_STORE_H_
#define HDRSTEREO_DAEMON_STORE_FILE_STORE_H_

#include <cstdint>
#include <filesystem>
#include <set>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::store {

class FileStore {
 public:
  // Creates the data root and its folders if needed; fails with
  // FAILED_PRECONDITION when it is not a folder or not writable.
  static absl::StatusOr<FileStore> Open(const std::filesystem::path& root);

  const std::filesystem::path& root() const { return root_; }
  std::filesystem::path database_path() const { return root_ / "hdrstereo.db"; }
  std::filesystem::path SessionDir(absl::string_view session) const;
  std::filesystem::path JobDir(absl::string_view session, int64_t job_id) const;

  // Creates an empty session folder. A folder already there (left by a crash
  // before its database row was committed) is moved to orphaned/ first.
  absl::Status CreateSessionDir(absl::string_view session);
  // Moves the folder to trash/ (one rename, so it vanishes at once) and then
  // removes it. Missing folders are fine.
  absl::Status RemoveSessionDir(absl::string_view session);

  // Writes `relative` (inside the session folder: io::ValidateRelativePath)
  // atomically, creating parent folders. A full disk is io::IsDiskFull
  // (RESOURCE_EXHAUSTED naming the path and the free space) and leaves
  // neither the file nor a temporary one.
  absl::Status WriteSessionFile(absl::string_view session,
                                const std::filesystem::path& relative,
                                absl::string_view data);

  // Start-up housekeeping: empties trash/, moves session folders that have no
  // database row to orphaned/, and removes temporary files left by writers
  // that crashed. Returns the number of folders moved to orphaned/.
  absl::StatusOr<int> Sweep(const std::set<std::string>& known_sessions);

 private:
  explicit FileStore(std::filesystem::path root) : root_(std::move(root)) {}
  absl::Status MoveToOrphaned(const std::filesystem::path& dir);

  std::filesystem::path root_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_FILE_STORE_H_
