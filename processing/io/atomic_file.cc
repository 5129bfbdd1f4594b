// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <random>
#include <system_error>

#include "absl/status/statusor.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/string_view.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::io {
namespace {

absl::Status ErrnoStatus(int err, absl::string_view what,
                         const std::filesystem::path& path) {
  return absl::ErrnoToStatus(err, absl::StrCat(what, " ", path.string()));
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
  if (fd < 0) return ErrnoStatus(errno, "cannot create", temp);
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
      return ErrnoStatus(errno, "cannot write", temp_path_);
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
    absl::Status status = ErrnoStatus(errno, "cannot fsync", temp_path_);
    Abandon();
    return status;
  }
  if (::close(std::exchange(fd_, -1)) != 0) {
    absl::Status status = ErrnoStatus(errno, "cannot close", temp_path_);
    ::unlink(temp_path_.c_str());
    return status;
  }
  if (::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    absl::Status status = ErrnoStatus(errno, "cannot rename onto", path_);
    ::unlink(temp_path_.c_str());
    return status;
  }
  return SyncDirectory(path_.parent_path().empty() ? "." : path_.parent_path());
}

absl::Status WriteFileAtomically(const std::filesystem::path& path,
                                 absl::string_view data) {
  ASSIGN_OR_RETURN(AtomicFileWriter writer, AtomicFileWriter::Open(path));
  RETURN_IF_ERROR(writer.Append(data));
  return writer.Commit();
}

absl::Status SyncDirectory(const std::filesystem::path& dir) {
  int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return ErrnoStatus(errno, "cannot open folder", dir);
  int rc = ::fsync(fd);
  int err = errno;
  ::close(fd);
  if (rc != 0) return ErrnoStatus(err, "cannot fsync folder", dir);
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
