// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <system_error>

#include "absl/status/statusor.h"
#include "absl/strings/cord.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::io {
namespace {

// Marks a disk-full error (IsDiskFull); the payload is the errno's name.
constexpr absl::string_view kDiskFullPayload = "hdrstereo.io/disk-full";

// Free bytes for an unprivileged writer on the filesystem of `path` (of its
// nearest folder that exists); -1 when none can be asked.
int64_t FreeBytesNear(const std::filesystem::path& path) {
  for (std::filesystem::path p = path.parent_path(); !p.empty();
       p = p.parent_path()) {
    struct statvfs fs;
    if (::statvfs(p.c_str(), &fs) == 0) {
      return static_cast<int64_t>(fs.f_bavail) *
             static_cast<int64_t>(fs.f_frsize);
    }
    if (p == p.parent_path()) break;
  }
  return -1;
}

std::string RandomSuffix() {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  return absl::StrFormat("%016x", rng());
}

}  // namespace

absl::StatusOr<AtomicFileWriter> AtomicFileWriter::Open(
    std::filesystem::path path) {
  std::filesystem::path temp = path;
  temp += absl::StrCat(kTempFileMarker, RandomSuffix());
  int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return FileError(errno, "cannot create", temp);
  return AtomicFileWriter(std::move(path), std::move(temp), fd);
}

AtomicFileWriter::AtomicFileWriter(AtomicFileWriter&& other) noexcept
    : path_(std::move(other.path_)),
      temp_path_(std::move(other.temp_path_)),
      fd_(std::exchange(other.fd_, -1)) {}

AtomicFileWriter& AtomicFileWriter::operator=(
    AtomicFileWriter&& other) noexcept {
  if (this != &other) {
    Abandon();
    path_ = std::move(other.path_);
    temp_path_ = std::move(other.temp_path_);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

AtomicFileWriter::~AtomicFileWriter() { Abandon(); }

void AtomicFileWriter::Abandon() {
  if (fd_ < 0) return;
  ::close(fd_);
  fd_ = -1;
  ::unlink(temp_path_.c_str());
}

absl::Status AtomicFileWriter::Append(absl::string_view data) {
  if (fd_ < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("writer for ", path_.string(), " is already spent"));
  }
  while (!data.empty()) {
    ssize_t n = ::write(fd_, data.data(), data.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      Abandon();
      return FileError(err, "cannot write", path_);
    }
    data.remove_prefix(static_cast<size_t>(n));
  }
  return absl::OkStatus();
}

absl::Status AtomicFileWriter::Commit() {
  if (fd_ < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("writer for ", path_.string(), " is already spent"));
  }
  if (::fsync(fd_) != 0) {
    const int err = errno;
    Abandon();
    return FileError(err, "cannot fsync", path_);
  }
  if (::close(std::exchange(fd_, -1)) != 0) {
    const int err = errno;
    ::unlink(temp_path_.c_str());
    return FileError(err, "cannot close", path_);
  }
  if (::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    const int err = errno;
    ::unlink(temp_path_.c_str());
    return FileError(err, "cannot rename onto", path_);
  }
  return SyncDirectory(path_.parent_path().empty() ? "." : path_.parent_path());
}

absl::Status FileError(int err, absl::string_view what,
                       const std::filesystem::path& path) {
  absl::Status status =
      absl::ErrnoToStatus(err, absl::StrCat(what, " ", path.string()));
  if (err != ENOSPC && err != EDQUOT) return status;
  const absl::string_view name = err == ENOSPC ? "ENOSPC" : "EDQUOT";
  const int64_t free = FreeBytesNear(path);
  absl::Status full(
      absl::StatusCode::kResourceExhausted,
      absl::StrCat(
          "disk full (", name, "): ", status.message(),
          free >= 0 ? absl::StrCat("; ", free, " bytes free on its filesystem")
                    : ""));
  full.SetPayload(kDiskFullPayload, absl::Cord(name));
  return full;
}

bool IsDiskFull(const absl::Status& status) {
  return status.code() == absl::StatusCode::kResourceExhausted &&
         status.GetPayload(kDiskFullPayload).has_value();
}

absl::Status WriteFileAtomically(const std::filesystem::path& path,
                                 absl::string_view data) {
  ASSIGN_OR_RETURN(AtomicFileWriter writer, AtomicFileWriter::Open(path));
  RETURN_IF_ERROR(writer.Append(data));
  return writer.Commit();
}

absl::StatusOr<std::string> ReadFileBytes(const std::filesystem::path& path,
                                          size_t max_bytes,
                                          absl::string_view what) {
  // O_NONBLOCK: a FIFO is refused below instead of blocking the open until a
  // writer comes; reads of a regular file ignore it.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return FileError(errno, "cannot open", path);
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st;
  if (::fstat(fd, &st) != 0) return FileError(errno, "cannot stat", path);
  if (!S_ISREG(st.st_mode)) {
    return absl::FailedPreconditionError(
        absl::StrCat(path.string(), " is not a regular file"));
  }
  const uint64_t size = static_cast<uint64_t>(st.st_size);
  if (size > max_bytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        path.string(), ": ", what, " of ", size,
        " bytes, more than the limit of ", max_bytes, "; not read"));
  }
  // The file may grow after fstat: read at most one byte beyond the limit.
  std::string bytes;
  bytes.reserve(size);
  char chunk[16 << 10];
  for (;;) {
    const size_t room = max_bytes - bytes.size();
    const size_t want = room < sizeof(chunk) ? room + 1 : sizeof(chunk);
    const ssize_t n = ::read(fd, chunk, want);
    if (n < 0) {
      if (errno == EINTR) continue;
      return FileError(errno, "cannot read", path);
    }
    if (n == 0) return bytes;
    bytes.append(chunk, static_cast<size_t>(n));
    if (bytes.size() > max_bytes) {
      return absl::InvalidArgumentError(
          absl::StrCat(path.string(), ": ", what, " grew beyond the limit of ",
                       max_bytes, " bytes while it was read"));
    }
  }
}

absl::Status SyncDirectory(const std::filesystem::path& dir) {
  int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return FileError(errno, "cannot open folder", dir);
  int rc = ::fsync(fd);
  int err = errno;
  ::close(fd);
  if (rc != 0) return FileError(err, "cannot fsync folder", dir);
  return absl::OkStatus();
}

absl::StatusOr<int> RemoveStaleTempFiles(const std::filesystem::path& dir) {
  std::error_code ec;
  int removed = 0;
  for (auto it = std::filesystem::recursive_directory_iterator(dir, ec);
       !ec && it != std::filesystem::recursive_directory_iterator();
       it.increment(ec)) {
    if (it->is_regular_file() &&
        absl::StrContains(it->path().filename().string(), kTempFileMarker)) {
      if (std::filesystem::remove(it->path(), ec)) ++removed;
    }
  }
  if (ec) {
    return absl::InternalError(
        absl::StrCat("cannot clean ", dir.string(), ": ", ec.message()));
  }
  return removed;
}

}  // namespace hdrstereo::io
