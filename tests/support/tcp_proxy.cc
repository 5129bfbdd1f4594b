// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/tcp_proxy.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace hdrstereo::testing {
namespace {

sockaddr_in Loopback(int port) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return address;
}

// Forwards what is readable on `from` to `to`; false when `from` closed or
// failed.
bool Forward(int from, int to) {
  char buffer[16384];
  const ssize_t n = ::read(from, buffer, sizeof buffer);
  if (n <= 0) return false;
  for (ssize_t sent = 0; sent < n;) {
    const ssize_t m = ::write(to, buffer + sent, static_cast<size_t>(n - sent));
    if (m < 0 && errno == EINTR) continue;
    if (m <= 0) return false;
    sent += m;
  }
  return true;
}

}  // namespace

absl::StatusOr<std::unique_ptr<TcpProxy>> TcpProxy::Start(int target_port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return absl::ErrnoToStatus(errno, "socket");
  sockaddr_in address = Loopback(0);
  socklen_t length = sizeof address;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(fd, 64) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
    const int error = errno;
    ::close(fd);
    return absl::ErrnoToStatus(error, "bind/listen on 127.0.0.1");
  }
  std::unique_ptr<TcpProxy> proxy(
      new TcpProxy(fd, ntohs(address.sin_port), target_port));
  if (::pipe2(proxy->wake_, O_CLOEXEC | O_NONBLOCK) != 0) {
    return absl::ErrnoToStatus(errno, "pipe");
  }
  proxy->thread_ = std::thread([p = proxy.get()] { p->Loop(); });
  return proxy;
}

TcpProxy::~TcpProxy() {
  stopping_ = true;
  if (wake_[1] >= 0) (void)!::write(wake_[1], "x", 1);
  if (thread_.joinable()) thread_.join();
  ::close(listen_fd_);
  for (int fd : wake_) {
    if (fd >= 0) ::close(fd);
  }
}

std::string TcpProxy::address() const {
  return absl::StrCat("127.0.0.1:", port_);
}

int TcpProxy::CutAll() {
  std::lock_guard<std::mutex> lock(cut_mutex_);
  cut_count_ = -1;
  cut_ = true;
  (void)!::write(wake_[1], "x", 1);
  // The relay thread answers within one poll round.
  for (int i = 0; i < 1000 && cut_; ++i) absl::SleepFor(absl::Milliseconds(2));
  return cut_count_;
}

void TcpProxy::Loop() {
  std::vector<std::pair<int, int>> pairs;  // (client, target)
  while (!stopping_) {
    std::vector<pollfd> fds = {{listen_fd_, POLLIN, 0}, {wake_[0], POLLIN, 0}};
    for (const auto& [client, target] : pairs) {
      fds.push_back({client, POLLIN, 0});
      fds.push_back({target, POLLIN, 0});
    }
    if (::poll(fds.data(), fds.size(), 200) < 0 && errno != EINTR) break;
    if (fds[1].revents != 0) {
      char drain[64];
      while (::read(wake_[0], drain, sizeof drain) > 0) {
      }
    }
    if (cut_) {
      for (const auto& [client, target] : pairs) {
        ::shutdown(client, SHUT_RDWR);
        ::close(client);
        ::close(target);
      }
      cut_count_ = static_cast<int>(pairs.size());
      pairs.clear();
      cut_ = false;
      continue;
    }
    std::vector<std::pair<int, int>> alive;
    for (size_t i = 0; i < pairs.size(); ++i) {
      const auto [client, target] = pairs[i];
      bool ok = true;
      if (fds[2 + 2 * i].revents != 0) ok = Forward(client, target);
      if (ok && fds[3 + 2 * i].revents != 0) ok = Forward(target, client);
      if (ok) {
        alive.push_back(pairs[i]);
      } else {
        ::close(client);
        ::close(target);
      }
    }
    pairs = std::move(alive);
    if (fds[0].revents != 0) {
      const int client = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (client < 0) continue;
      const int target = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
      sockaddr_in address = Loopback(target_port_);
      if (target < 0 || ::connect(target, reinterpret_cast<sockaddr*>(&address),
                                  sizeof address) != 0) {
        ::close(client);
        if (target >= 0) ::close(target);
        continue;
      }
      ++accepted_;
      pairs.emplace_back(client, target);
    }
  }
  for (const auto& [client, target] : pairs) {
    ::close(client);
    ::close(target);
  }
}

}  // namespace hdrstereo::testing
