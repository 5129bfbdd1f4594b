// SPDX-License-Identifier: GPL-3.0-or-later
//
// Server-side sessions of browsers signed in with an API key: the browser
// holds only a random token in an HttpOnly cookie; the daemon keeps the
// token's SHA-256, the key's id and the session's times, in memory. A
// session ends when the browser signs out, when it was idle too long, at
// its absolute expiry, or when the daemon restarts (sessions are not
// stored: after a restart people sign in again). Revoking the key ends its
// sessions at once: the edge checks the key on every request.
#ifndef HDRSTEREO_DAEMON_HTTP_BROWSER_SESSIONS_H_
#define HDRSTEREO_DAEMON_HTTP_BROWSER_SESSIONS_H_

#include <cstddef>
#include <functional>
#include <map>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace hdrstereo::http {

struct BrowserSessionOptions {
  absl::Duration idle_timeout = absl::Minutes(30);
  absl::Duration lifetime = absl::Hours(12);
  // Sessions held at once; a sign-in beyond it ends the session used
  // longest ago.
  size_t max_sessions = 4096;
};

struct BrowserSession {
  std::string key_id;  // the API key it was signed in with
  absl::Time start;
  absl::Time last_use;
};

class BrowserSessions {
 public:
  explicit BrowserSessions(
      BrowserSessionOptions options,
      std::function<absl::Time()> clock = [] { return absl::Now(); })
      : options_(options), clock_(std::move(clock)) {}

  // A new session for the key `key_id`: its token (256 random bits, 64 hex
  // digits), for the cookie. INTERNAL when OpenSSL has no randomness.
  absl::StatusOr<std::string> Start(absl::string_view key_id)
      ABSL_LOCKS_EXCLUDED(mutex_);
  // The session of `token`, its last use now; UNAUTHENTICATED when there
  // is none (unknown token, signed out, idle or past its lifetime, or the
  // daemon restarted since), saying to sign in again.
  absl::StatusOr<BrowserSession> Use(absl::string_view token)
      ABSL_LOCKS_EXCLUDED(mutex_);
  // Ends the session of `token` (sign-out); false when there was none.
  bool End(absl::string_view token) ABSL_LOCKS_EXCLUDED(mutex_);

  size_t size() ABSL_LOCKS_EXCLUDED(mutex_);
  const BrowserSessionOptions& options() const { return options_; }

 private:
  bool Expired(const BrowserSession& session, absl::Time now) const;

  const BrowserSessionOptions options_;
  const std::function<absl::Time()> clock_;
  absl::Mutex mutex_;
  // By SHA-256 of the token (hex): the tokens themselves are not kept.
  std::map<std::string, BrowserSession, std::less<>> sessions_
      ABSL_GUARDED_BY(mutex_);
};

}  // namespace hdrstereo::http

#endif  // HDRSTEREO_DAEMON_HTTP_BROWSER_SESSIONS_H_
