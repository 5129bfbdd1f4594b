// SPDX-License-Identifier: GPL-3.0-or-later
//
// A byte-for-byte TCP relay on a free loopback port to a loopback target,
// which a test can cut: every relayed connection is closed at once (as a
// network drop would), new ones are accepted and relayed again. It sees TLS
// as opaque bytes. Its thread stops with the object.
#ifndef HDRSTEREO_TESTS_SUPPORT_TCP_PROXY_H_
#define HDRSTEREO_TESTS_SUPPORT_TCP_PROXY_H_

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

namespace hdrstereo::testing {

class TcpProxy {
 public:
  // Relays 127.0.0.1:<free port> to 127.0.0.1:`target_port`.
  static absl::StatusOr<std::unique_ptr<TcpProxy>> Start(int target_port);
  ~TcpProxy();

  std::string address() const;  // "127.0.0.1:PORT"
  // Closes every relayed connection; returns how many there were.
  int CutAll();
  int connections_accepted() const { return accepted_; }

 private:
  TcpProxy(int listen_fd, int port, int target_port)
      : listen_fd_(listen_fd), port_(port), target_port_(target_port) {}
  void Loop();

  const int listen_fd_;
  const int port_;
  const int target_port_;
  int wake_[2] = {-1, -1};  // a pipe that interrupts poll()
  std::atomic<bool> stopping_{false};
  std::atomic<bool> cut_{false};
  std::atomic<int> accepted_{0};
  std::atomic<int> cut_count_{0};
  std::mutex cut_mutex_;
  std::thread thread_;
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_TCP_PROXY_H_
