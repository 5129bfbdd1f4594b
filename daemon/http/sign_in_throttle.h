// SPDX-License-Identifier: GPL-3.0-or-later
//
// Failed sign-ins per peer address: after `max_failures` within `window`,
// further sign-ins from that address are refused until the oldest of those
// failures is older than the window. Guessing a 256-bit key is hopeless
// anyway; this keeps a misconfigured script or a scanner from filling the
// audit log and the CPU.
#ifndef HDRSTEREO_DAEMON_HTTP_SIGN_IN_THROTTLE_H_
#define HDRSTEREO_DAEMON_HTTP_SIGN_IN_THROTTLE_H_

#include <cstddef>
#include <deque>
#include <functional>
#include <map>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace hdrstereo::http {

struct SignInThrottleOptions {
  int max_failures = 10;
  absl::Duration window = absl::Minutes(1);
  // Addresses remembered at once (the oldest are forgotten first).
  size_t max_peers = 10000;
};

class SignInThrottle {
 public:
  explicit SignInThrottle(
      SignInThrottleOptions options,
      std::function<absl::Time()> clock = [] { return absl::Now(); })
      : options_(options), clock_(std::move(clock)) {}

  // RESOURCE_EXHAUSTED, saying when to try again, while `address` (an IP
  // address, without port) has too many recent failures.
  absl::Status Check(absl::string_view address) ABSL_LOCKS_EXCLUDED(mutex_);
  void RecordFailure(absl::string_view address) ABSL_LOCKS_EXCLUDED(mutex_);

 private:
  // Drops the failures older than the window.
  void Prune(std::deque<absl::Time>& failures, absl::Time now) const;

  const SignInThrottleOptions options_;
  const std::function<absl::Time()> clock_;
  absl::Mutex mutex_;
  std::map<std::string, std::deque<absl::Time>, std::less<>> failures_
      ABSL_GUARDED_BY(mutex_);
};

}  // namespace hdrstereo::http

#endif  // HDRSTEREO_DAEMON_HTTP_SIGN_IN_THROTTLE_H_
