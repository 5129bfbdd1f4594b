// SPDX-License-Identifier: GPL-3.0-or-later
//
// Crash-safe file writes: data goes to a temporary file in the target's
// folder, is fsynced, renamed over the target and the folder is fsynced.
// A reader therefore sees either the old file or the complete new one, never
// a partial write, even after a power cut or kill -9.
//
// And the bounded read of a file received from others (ReadFileBytes with
// a limit), here because this library is light enough for every reader of
// such files: the CLI and the gphoto2 driver as well as processing.
#ifndef HDRSTEREO_PROCESSING_IO_ATOMIC_FILE_H_
#define HDRSTEREO_PROCESSING_IO_ATOMIC_FILE_H_

#include <cstddef>
#include <filesystem>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::io {

// Temporary files are named "<target>.tmp-<random>" so that stale ones from a
// crashed writer can be recognised and removed.
inline constexpr absl::string_view kTempFileMarker = ".tmp-";

// Writes a file in pieces; nothing is visible at `path` until Commit()
// succeeds. Destroying an uncommitted writer removes its temporary file, and
// so does a failed Append() or Commit(): the space a write that ran out of it
// had taken is free again when the error is returned.
class AtomicFileWriter {
 public:
  // Creates the temporary file. Parent folders must exist.
  static absl::StatusOr<AtomicFileWriter> Open(std::filesystem::path path);

  AtomicFileWriter(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter& operator=(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter();

  // A failed Append spends the writer (see above).
  absl::Status Append(absl::string_view data);
  // fsync, rename over the target, fsync the folder. The writer is spent
  // afterwards, whether or not this succeeds.
  absl::Status Commit();

  const std::filesystem::path& temp_path() const { return temp_path_; }

 private:
  AtomicFileWriter(std::filesystem::path path, std::filesystem::path temp,
                   int fd)
      : path_(std::move(path)), temp_path_(std::move(temp)), fd_(fd) {}
  void Abandon();

  std::filesystem::path path_;
  std::filesystem::path temp_path_;
  int fd_ = -1;
};

// The status of a file operation (`what`, e.g. "cannot write") on `path`
// that failed with errno `err`: absl::ErrnoToStatus's code and "WHAT PATH:
// strerror". ENOSPC and EDQUOT (no space left, quota full) are a disk-full
// error instead (IsDiskFull), which also names the free space left on the
// filesystem of `path`.
absl::Status FileError(int err, absl::string_view what,
                       const std::filesystem::path& path);

// True for the error of a write that found its filesystem full (FileError
// with ENOSPC or EDQUOT): RESOURCE_EXHAUSTED "disk full: cannot write PATH:
// No space left on device; N bytes free on its filesystem", marked so that
// it is told apart from other exhausted resources (open files, memory).
bool IsDiskFull(const absl::Status& status);

// Writes `data` to `path` atomically (see above); a disk-full error names
// `path` and leaves no temporary file.
absl::Status WriteFileAtomically(const std::filesystem::path& path,
                                 absl::string_view data);

// The bytes of a file received from others (a layout, a scene, a camera
// dump, a cluster node's result), refused by its size before anything is
// read or allocated: INVALID_ARGUMENT "<path>: <what> of N bytes, more than
// the limit of <max_bytes>; not read" (or, for a file that grows past the
// limit while it is read, "<path>: <what> grew beyond the limit of
// <max_bytes> bytes while it was read"). Those are the only INVALID_ARGUMENT
// errors it returns, so that a caller may give them its own code. A file
// that cannot be opened or read is FileError's status (NOT_FOUND when it
// does not exist), one that is not a regular file (a folder, a FIFO, a
// device) FAILED_PRECONDITION.
absl::StatusOr<std::string> ReadFileBytes(const std::filesystem::path& path,
                                          size_t max_bytes,
                                          absl::string_view what);

// fsyncs a folder so that a rename or new entry in it is durable.
absl::Status SyncDirectory(const std::filesystem::path& dir);

// Removes temporary files left anywhere below `dir` by writers that crashed
// before committing. Returns how many were removed.
absl::StatusOr<int> RemoveStaleTempFiles(const std::filesystem::path& dir);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_ATOMIC_FILE_H_
