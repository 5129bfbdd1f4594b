// SPDX-License-Identifier: GPL-3.0-or-later
//
// Crash-safe file writes: data goes to a temporary file in the target's
// folder, is fsynced, renamed over the target and the folder is fsynced.
// A reader therefore sees either the old file or the complete new one, never
// a partial write, even after a power cut or kill -9.
#ifndef HDRSTEREO_PROCESSING_IO_ATOMIC_FILE_H_
#define HDRSTEREO_PROCESSING_IO_ATOMIC_FILE_H_

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
// succeeds. Destroying an uncommitted writer removes its temporary file.
class AtomicFileWriter {
 public:
  // Creates the temporary file. Parent folders must exist.
  static absl::StatusOr<AtomicFileWriter> Open(std::filesystem::path path);

  AtomicFileWriter(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter& operator=(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter();

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

// Writes `data` to `path` atomically (see above).
absl::Status WriteFileAtomically(const std::filesystem::path& path,
                                 absl::string_view data);

// fsyncs a folder so that a rename or new entry in it is durable.
absl::Status SyncDirectory(const std::filesystem::path& dir);

// Removes temporary files left anywhere below `dir` by writers that crashed
// before committing. Returns how many were removed.
absl::StatusOr<int> RemoveStaleTempFiles(const std::filesystem::path& dir);

}  // namespace hdrstereo::io

#endif  // HDRSTEREO_PROCESSING_IO_ATOMIC_FILE_H_
