// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/http/sign_in_throttle.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

namespace hdrstereo::http {

void SignInThrottle::Prune(std::deque<absl::Time>& failures,
                           absl::Time now) const {
  while (!failures.empty() && now - failures.front() >= options_.window) {
    failures.pop_front();
  }
}

absl::Status SignInThrottle::Check(absl::string_view address) {
  const absl::Time now = clock_();
  absl::MutexLock lock(&mutex_);
  auto it = failures_.find(address);
  if (it == failures_.end()) return absl::OkStatus();
  Prune(it->second, now);
  if (static_cast<int>(it->second.size()) < options_.max_failures) {
    return absl::OkStatus();
  }
  const double wait_s = std::ceil(
      absl::ToDoubleSeconds(it->second.front() + options_.window - now));
  return absl::ResourceExhaustedError(absl::StrCat(
      "too many failed sign-ins from ", address, " (", it->second.size(),
      " in the last ", absl::FormatDuration(options_.window),
      "); try again in ", std::max(1.0, wait_s), " s"));
}

void SignInThrottle::RecordFailure(absl::string_view address) {
  const absl::Time now = clock_();
  absl::MutexLock lock(&mutex_);
  auto it = failures_.find(address);
  if (it == failures_.end()) {
    if (failures_.size() >= options_.max_peers) {
      // Forget the address whose last failure is oldest.
      failures_.erase(std::min_element(
          failures_.begin(), failures_.end(), [](const auto& a, const auto& b) {
            const absl::Time ta =
                a.second.empty() ? absl::InfinitePast() : a.second.back();
            const absl::Time tb =
                b.second.empty() ? absl::InfinitePast() : b.second.back();
            return ta < tb;
          }));
    }
    it =
        failures_.emplace(std::string(address), std::deque<absl::Time>()).first;
  }
  Prune(it->second, now);
  it->second.push_back(now);
  // Never more than needed to decide.
  while (static_cast<int>(it->second.size()) > options_.max_failures) {
    it->second.pop_front();
  }
}

}  // namespace hdrstereo::http
