// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/http/browser_sessions.h"

#include <openssl/rand.h>

#include <algorithm>

#include "absl/strings/escaping.h"
#include "processing/io/sha256.h"

namespace hdrstereo::http {
namespace {

constexpr size_t kTokenBytes = 32;

}  // namespace

bool BrowserSessions::Expired(const BrowserSession& session,
                              absl::Time now) const {
  return now - session.last_use >= options_.idle_timeout ||
         now - session.start >= options_.lifetime;
}

absl::StatusOr<std::string> BrowserSessions::Start(absl::string_view key_id) {
  std::string raw(kTokenBytes, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(raw.data()),
                 static_cast<int>(raw.size())) != 1) {
    return absl::InternalError("OpenSSL RAND_bytes failed");
  }
  std::string token = absl::BytesToHexString(raw);
  const absl::Time now = clock_();
  absl::MutexLock lock(&mutex_);
  // Expired sessions go first; then, if still full, the least recently used.
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    it = Expired(it->second, now) ? sessions_.erase(it) : std::next(it);
  }
  if (sessions_.size() >= options_.max_sessions && !sessions_.empty()) {
    sessions_.erase(std::min_element(
        sessions_.begin(), sessions_.end(), [](const auto& a, const auto& b) {
          return a.second.last_use < b.second.last_use;
        }));
  }
  sessions_[io::Sha256Hex(token)] =
      BrowserSession{std::string(key_id), now, now};
  return token;
}

absl::StatusOr<BrowserSession> BrowserSessions::Use(absl::string_view token) {
  const std::string digest = io::Sha256Hex(token);
  const absl::Time now = clock_();
  absl::MutexLock lock(&mutex_);
  auto it = sessions_.find(digest);
  if (it == sessions_.end() || Expired(it->second, now)) {
    if (it != sessions_.end()) sessions_.erase(it);
    return absl::UnauthenticatedError(
        "the browser session has ended (signed out, idle too long, expired, "
        "or hdrstereod restarted): sign in again with an API key");
  }
  it->second.last_use = now;
  return it->second;
}

bool BrowserSessions::End(absl::string_view token) {
  absl::MutexLock lock(&mutex_);
  return sessions_.erase(io::Sha256Hex(token)) > 0;
}

size_t BrowserSessions::size() {
  absl::MutexLock lock(&mutex_);
  return sessions_.size();
}

}  // namespace hdrstereo::http
