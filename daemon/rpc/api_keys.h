// SPDX-License-Identifier: GPL-3.0-or-later
//
// API keys for scripts and notebooks: "hs_<id>_<secret>", where <id> (12 hex
// digits) is public and <secret> is 256 random bits (64 hex digits) from
// OpenSSL's RAND_bytes. The daemon keeps id, a random salt and
// SHA-256(salt || secret) (OpenSSL EVP) and compares digests in constant
// time (CRYPTO_memcmp); the secret is shown once, at creation, and never
// stored or logged. Keys are held in memory (mirroring SQLite) so that a
// call is verified without touching the database; creation and revocation
// write through, so a revoked key fails on its next call.
#ifndef HDRSTEREO_DAEMON_RPC_API_KEYS_H_
#define HDRSTEREO_DAEMON_RPC_API_KEYS_H_

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "daemon/rpc/roles.h"
#include "daemon/store/api_key_repository.h"

namespace hdrstereo::rpc {

inline constexpr absl::Duration kMaxApiKeyTtl = absl::Hours(24 * 366);

struct NewApiKey {
  store::ApiKeyRecord record;
  std::string token;  // hs_<id>_<secret>: to be shown once
};

struct VerifiedApiKey {
  std::string id;
  std::string user;
  Role role = Role::kNone;
  absl::Time expire_time;
};

// The id of a token shaped like hs_<id>_<secret>, or "" when it is not.
std::string ApiKeyIdOf(absl::string_view token);

class ApiKeyStore {
 public:
  static absl::StatusOr<std::unique_ptr<ApiKeyStore>> Load(
      store::Store& store,
      std::function<absl::Time()> clock = [] { return absl::Now(); });

  // The caller has checked that `created_by` may and that `role` does not
  // exceed the user's. INVALID_ARGUMENT for a ttl outside (0, 366 days] or
  // a note over 1 KiB.
  absl::StatusOr<NewApiKey> Create(absl::string_view user, Role role,
                                   absl::Duration ttl, absl::string_view note,
                                   absl::string_view created_by);
  // UNAUTHENTICATED, with a message a person can act on and without the
  // secret, for a malformed, unknown, wrong, expired or revoked key.
  absl::StatusOr<VerifiedApiKey> Verify(absl::string_view token);
  // The key with id `id` if it is still in force (neither revoked nor
  // expired), without its secret: for a browser session signed in with the
  // key, checked again on every request so that revoking the key ends its
  // sessions at once. UNAUTHENTICATED otherwise.
  absl::StatusOr<VerifiedApiKey> Active(absl::string_view id);
  // NOT_FOUND for an unknown id; FAILED_PRECONDITION if already revoked.
  absl::StatusOr<store::ApiKeyRecord> Revoke(absl::string_view id,
                                             absl::string_view by);
  // Keys of `user` ("" = everyone), oldest first; revoked and expired ones
  // only with `include_inactive`.
  std::vector<store::ApiKeyRecord> List(absl::string_view user,
                                        bool include_inactive);

 private:
  ApiKeyStore(store::Store& store, std::function<absl::Time()> clock)
      : repository_(store), clock_(std::move(clock)) {}

  // The key as verified at `now` (UNAUTHENTICATED when revoked or expired);
  // sets `persist_last_used` to its id when its last use is due to be
  // written.
  absl::StatusOr<VerifiedApiKey> Use(store::ApiKeyRecord& key, absl::Time now,
                                     std::string* persist_last_used)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void PersistLastUsed(const std::string& id, absl::Time now);

  store::ApiKeyRepository repository_;
  std::function<absl::Time()> clock_;
  absl::Mutex mutex_;
  // By id.
  std::map<std::string, store::ApiKeyRecord, std::less<>> keys_
      ABSL_GUARDED_BY(mutex_);
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_API_KEYS_H_
