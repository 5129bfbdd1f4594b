// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/free_ports.h"

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <random>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace hdrstereo::testing {
namespace {

// The low end of the kernel's range for ports it hands out by itself
// (connect(), bind() to port 0).
int EphemeralRangeStart() {
  std::ifstream in("/proc/sys/net/ipv4/ip_local_port_range");
  int low = 32768;
  in >> low;
  return low;
}

}  // namespace

absl::StatusOr<std::vector<int>> FreeLoopbackPorts(int count) {
  const int below = EphemeralRangeStart();
  std::mt19937 random(static_cast<uint32_t>(
      absl::ToUnixNanos(absl::Now()) ^ (static_cast<int64_t>(getpid()) << 16)));
  std::vector<int> held;  // sockets bound to the ports chosen so far
  std::vector<int> ports;
  for (int i = 0; i < count; ++i) {
    for (int attempt = 0; attempt <= 100; ++attempt) {
      const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
      if (fd < 0) break;
      sockaddr_in addr{};
      addr.sin_family = AF_INET;
      addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      // 100 draws below the range, then the kernel's choice.
      if (attempt < 100 && below > 11024) {
        addr.sin_port = htons(static_cast<uint16_t>(
            std::uniform_int_distribution<int>(10000, below - 1)(random)));
      }
      socklen_t length = sizeof addr;
      if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
          ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &length) == 0) {
        held.push_back(fd);
        ports.push_back(ntohs(addr.sin_port));
        break;
      }
      ::close(fd);
    }
  }
  for (int fd : held) ::close(fd);
  if (static_cast<int>(ports.size()) != count) {
    return absl::InternalError(
        absl::StrCat("no ", count, " free ports on 127.0.0.1"));
  }
  return ports;
}

}  // namespace hdrstereo::testing
