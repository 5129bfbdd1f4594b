// SPDX-License-Identifier: GPL-3.0-or-later
//
// API keys (table `api_keys`): what is needed to verify a key (its id, a
// salt and the SHA-256 digest of salt and secret, both hex) and facts about
// it. The secret itself is never stored.
#ifndef HDRSTEREO_DAEMON_STORE_API_KEY_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_API_KEY_REPOSITORY_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

struct ApiKeyRecord {
  std::string id;
  std::string salt_hex;
  std::string digest_hex;
  std::string user;
  std::string role;  // "viewer", "operator" or "admin"
  std::string note;
  std::string created_by;
  int64_t create_time_ms = 0;
  int64_t expire_time_ms = 0;
  std::optional<int64_t> last_used_time_ms;
  std::optional<int64_t> revoke_time_ms;
  std::string revoked_by;
};

class ApiKeyRepository {
 public:
  explicit ApiKeyRepository(Store& store) : store_(store) {}

  // ALREADY_EXISTS when the id is taken.
  absl::Status Insert(const ApiKeyRecord& key);
  // Every key, oldest first.
  absl::StatusOr<std::vector<ApiKeyRecord>> All();
  // Marks the key revoked; NOT_FOUND for an unknown id, FAILED_PRECONDITION
  // when it already is.
  absl::StatusOr<ApiKeyRecord> Revoke(absl::string_view id, int64_t now_ms,
                                      absl::string_view by);
  absl::Status SetLastUsed(absl::string_view id, int64_t time_ms);

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_API_KEY_REPOSITORY_H_
