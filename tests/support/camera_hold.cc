// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/camera_hold.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <future>

namespace hdrstereo::testing {
namespace {

// Blocks until a reader (the camera) has the FIFO open.
int OpenForWriting(const std::filesystem::path& path) {
  int fd = -1;
  do {
    fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  } while (fd < 0 && errno == EINTR);
  return fd;
}

}  // namespace

CameraHold::CameraHold(std::filesystem::path path) : path_(std::move(path)) {
  if (::mkfifo(path_.c_str(), 0600) != 0) {
    ADD_FAILURE() << "mkfifo " << path_ << ": " << std::strerror(errno);
  }
}

CameraHold::~CameraHold() {
  // A camera waiting to open the FIFO lets a non-blocking writer in.
  if (fd_ < 0) fd_ = ::open(path_.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
  Release();
  ::unlink(path_.c_str());
}

bool CameraHold::WaitUntilHeld(absl::Duration timeout) {
  if (timeout == absl::InfiniteDuration()) {
    fd_ = OpenForWriting(path_);
    return fd_ >= 0;
  }
  std::future<int> opened =
      std::async(std::launch::async, OpenForWriting, path_);
  if (opened.wait_for(absl::ToChronoMilliseconds(timeout)) ==
      std::future_status::ready) {
    fd_ = opened.get();
    return fd_ >= 0;
  }
  // Nobody came: a reader of our own ends the blocked open.
  const int reader = ::open(path_.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  const int writer = opened.get();
  if (writer >= 0) ::close(writer);
  if (reader >= 0) ::close(reader);
  return false;
}

void CameraHold::Release() {
  if (fd_ < 0) return;
  // A camera that went away (the daemon was killed) makes the write fail
  // with EPIPE; its SIGPIPE is blocked here and taken back, not delivered.
  sigset_t pipe_only;
  sigset_t before;
  sigemptyset(&pipe_only);
  sigaddset(&pipe_only, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_only, &before);
  const char byte = 1;
  if (::write(fd_, &byte, 1) != 1 && errno == EPIPE) {
    const timespec now = {0, 0};
    sigtimedwait(&pipe_only, nullptr, &now);
  }
  pthread_sigmask(SIG_SETMASK, &before, nullptr);
  ::close(fd_);
  fd_ = -1;
}

}  // namespace hdrstereo::testing
