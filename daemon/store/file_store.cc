// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/store/file_store.h"

#include <unistd.h>

#include <system_error>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/relative_path.h"

namespace hdrstereo::store {
namespace fs = std::filesystem;
namespace {

absl::Status FsError(const std::error_code& ec, absl::string_view what,
                     const fs::path& path) {
  return absl::InternalError(
      absl::StrCat(what, " ", path.string(), ": ", ec.message()));
}

std::string TimeTag() {
  return absl::FormatTime("%Y%m%dT%H%M%E3SZ", absl::Now(), absl::UTCTimeZone());
}

}  // namespace

absl::StatusOr<FileStore> FileStore::Open(const fs::path& root) {
  std::error_code ec;
  fs::path absolute = fs::absolute(root, ec);
  if (ec) return FsError(ec, "cannot resolve data root", root);
  if (fs::exists(absolute, ec) && !fs::is_directory(absolute, ec)) {
    return absl::FailedPreconditionError(
        absl::StrCat("data root ", absolute.string(), " is not a folder"));
  }
  for (const char* sub : {"sessions", "trash", "orphaned"}) {
    fs::create_directories(absolute / sub, ec);
    if (ec) {
      return absl::FailedPreconditionError(absl::StrCat(
          "data root ", absolute.string(), " is not writable: cannot create ",
          sub, "/: ", ec.message()));
    }
  }
  // Permission bits say little for root or on read-only mounts: try a write.
  fs::path probe = absolute / ".write-probe";
  if (absl::Status s = io::WriteFileAtomically(probe, "ok"); !s.ok()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "data root ", absolute.string(), " is not writable: ", s.message()));
  }
  fs::remove(probe, ec);
  return FileStore(fs::canonical(absolute));
}

fs::path FileStore::SessionDir(absl::string_view session) const {
  return root_ / "sessions" / std::string(session);
}

fs::path FileStore::JobDir(absl::string_view session, int64_t job_id) const {
  return SessionDir(session) / "jobs" / std::to_string(job_id);
}

absl::Status FileStore::MoveToOrphaned(const fs::path& dir) {
  fs::path target =
      root_ / "orphaned" /
      absl::StrCat(dir.filename().string(), "-", TimeTag(), "-", ::getpid());
  std::error_code ec;
  fs::rename(dir, target, ec);
  if (ec) return FsError(ec, "cannot move aside", dir);
  return io::SyncDirectory(dir.parent_path());
}

absl::Status FileStore::CreateSessionDir(absl::string_view session) {
  fs::path dir = SessionDir(session);
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    RETURN_IF_ERROR(MoveToOrphaned(dir));
  }
  fs::create_directory(dir, ec);
  if (ec) return FsError(ec, "cannot create", dir);
  return io::SyncDirectory(dir.parent_path());
}

absl::Status FileStore::RemoveSessionDir(absl::string_view session) {
  fs::path dir = SessionDir(session);
  std::error_code ec;
  if (!fs::exists(dir, ec)) return absl::OkStatus();
  fs::path doomed =
      root_ / "trash" / absl::StrCat(session, "-", TimeTag(), "-", ::getpid());
  fs::rename(dir, doomed, ec);
  if (ec) return FsError(ec, "cannot move to trash", dir);
  fs::remove_all(doomed, ec);
  if (ec) return FsError(ec, "cannot remove", doomed);
  return absl::OkStatus();
}

absl::Status FileStore::WriteSessionFile(absl::string_view session,
                                         const fs::path& relative,
                                         absl::string_view data) {
  RETURN_IF_ERROR(io::ValidateRelativePath(relative.native()));
  fs::path path = SessionDir(session) / relative;
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  // errno values: a full disk is told apart (io::IsDiskFull).
  if (ec) return io::FileError(ec.value(), "cannot create", path.parent_path());
  return io::WriteFileAtomically(path, data);
}

absl::StatusOr<int> FileStore::Sweep(
    const std::set<std::string>& known_sessions) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(root_ / "trash", ec)) {
    fs::remove_all(entry.path(), ec);
    if (ec) return FsError(ec, "cannot empty trash", entry.path());
  }
  if (ec) return FsError(ec, "cannot list", root_ / "trash");

  int orphaned = 0;
  for (const auto& entry : fs::directory_iterator(root_ / "sessions", ec)) {
    if (!entry.is_directory()) continue;
    if (known_sessions.contains(entry.path().filename().string())) {
      RETURN_IF_ERROR(io::RemoveStaleTempFiles(entry.path()).status());
    } else {
      RETURN_IF_ERROR(MoveToOrphaned(entry.path()));
      ++orphaned;
    }
  }
  if (ec) return FsError(ec, "cannot list", root_ / "sessions");
  return orphaned;
}

}  // namespace hdrstereo::store
