// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/api_keys.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <tuple>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::rpc {
namespace {

constexpr absl::string_view kPrefix = "hs_";
constexpr size_t kIdBytes = 6;       // 12 hex digits
constexpr size_t kSecretBytes = 32;  // 256 bits
constexpr size_t kSaltBytes = 16;
constexpr size_t kMaxNoteBytes = 1024;
// Writing the last-use time at most this often keeps the hot path off the
// database.
constexpr absl::Duration kLastUsedResolution = absl::Minutes(1);

absl::StatusOr<std::string> RandomHex(size_t bytes) {
  std::string raw(bytes, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(raw.data()),
                 static_cast<int>(raw.size())) != 1) {
    return absl::InternalError("OpenSSL RAND_bytes failed");
  }
  return absl::BytesToHexString(raw);
}

bool IsLowerHex(absl::string_view text) {
  for (char c : text) {
    if (!absl::ascii_isdigit(c) && (c < 'a' || c > 'f')) return false;
  }
  return true;
}

// SHA-256(salt || secret) as raw bytes.
absl::StatusOr<std::string> Digest(absl::string_view salt,
                                   absl::string_view secret) {
  unsigned char out[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  const bool ok = ctx != nullptr &&
                  EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr) == 1 &&
                  EVP_DigestUpdate(ctx, salt.data(), salt.size()) == 1 &&
                  EVP_DigestUpdate(ctx, secret.data(), secret.size()) == 1 &&
                  EVP_DigestFinal_ex(ctx, out, &length) == 1;
  EVP_MD_CTX_free(ctx);
  if (!ok) return absl::InternalError("OpenSSL SHA-256 failed");
  return std::string(reinterpret_cast<const char*>(out), length);
}

std::string FormatTime(int64_t ms) {
  return absl::FormatTime("%Y-%m-%d %H:%M %Z", absl::FromUnixMillis(ms),
                          absl::LocalTimeZone());
}

}  // namespace

std::string ApiKeyIdOf(absl::string_view token) {
  if (!absl::StartsWith(token, kPrefix)) return "";
  token.remove_prefix(kPrefix.size());
  if (token.size() != 2 * kIdBytes + 1 + 2 * kSecretBytes ||
      token[2 * kIdBytes] != '_') {
    return "";
  }
  const absl::string_view id = token.substr(0, 2 * kIdBytes);
  const absl::string_view secret = token.substr(2 * kIdBytes + 1);
  if (!IsLowerHex(id) || !IsLowerHex(secret)) return "";
  return std::string(id);
}

absl::StatusOr<std::unique_ptr<ApiKeyStore>> ApiKeyStore::Load(
    store::Store& store, std::function<absl::Time()> clock) {
  std::unique_ptr<ApiKeyStore> keys(new ApiKeyStore(store, std::move(clock)));
  ASSIGN_OR_RETURN(std::vector<store::ApiKeyRecord> all,
                   keys->repository_.All());
  absl::MutexLock lock(&keys->mutex_);  // not yet shared; for the analysis
  for (store::ApiKeyRecord& key : all) {
    std::string id = key.id;
    keys->keys_.emplace(std::move(id), std::move(key));
  }
  return keys;
}

absl::StatusOr<NewApiKey> ApiKeyStore::Create(absl::string_view user, Role role,
                                              absl::Duration ttl,
                                              absl::string_view note,
                                              absl::string_view created_by) {
  if (ttl <= absl::ZeroDuration() || ttl > kMaxApiKeyTtl) {
    return absl::InvalidArgumentError(
        absl::StrCat("ttl_s is ", absl::ToInt64Seconds(ttl),
                     "; a key lasts 1 s to 366 days (31622400 s)"));
  }
  if (note.size() > kMaxNoteBytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        "note has ", note.size(), " bytes; at most ", kMaxNoteBytes));
  }
  if (role == Role::kNone) {
    return absl::InvalidArgumentError("role must be viewer, operator or admin");
  }
  ASSIGN_OR_RETURN(std::string id, RandomHex(kIdBytes));
  ASSIGN_OR_RETURN(std::string secret, RandomHex(kSecretBytes));
  ASSIGN_OR_RETURN(std::string salt_hex, RandomHex(kSaltBytes));
  ASSIGN_OR_RETURN(std::string digest,
                   Digest(absl::HexStringToBytes(salt_hex), secret));
  const int64_t now_ms = absl::ToUnixMillis(clock_());
  store::ApiKeyRecord record;
  record.id = id;
  record.salt_hex = salt_hex;
  record.digest_hex = absl::BytesToHexString(digest);
  record.user = std::string(user);
  record.role = RoleName(role);
  record.note = std::string(note);
  record.created_by = std::string(created_by);
  record.create_time_ms = now_ms;
  record.expire_time_ms = now_ms + absl::ToInt64Milliseconds(ttl);
  RETURN_IF_ERROR(repository_.Insert(record));
  {
    absl::MutexLock lock(&mutex_);
    keys_.emplace(id, record);
  }
  return NewApiKey{.record = std::move(record),
                   .token = absl::StrCat(kPrefix, id, "_", secret)};
}

absl::StatusOr<VerifiedApiKey> ApiKeyStore::Use(
    store::ApiKeyRecord& key, absl::Time now, std::string* persist_last_used) {
  if (key.revoke_time_ms.has_value()) {
    return absl::UnauthenticatedError(absl::StrCat(
        "API key ", key.id, " was revoked at ", FormatTime(*key.revoke_time_ms),
        "; ask an admin for a new one"));
  }
  if (absl::ToUnixMillis(now) >= key.expire_time_ms) {
    return absl::UnauthenticatedError(absl::StrCat(
        "API key ", key.id, " expired at ", FormatTime(key.expire_time_ms),
        "; ask an admin for a new one"));
  }
  absl::StatusOr<Role> role = ParseRole(key.role);
  const int64_t now_ms = absl::ToUnixMillis(now);
  if (!key.last_used_time_ms.has_value() ||
      now_ms - *key.last_used_time_ms >=
          absl::ToInt64Milliseconds(kLastUsedResolution)) {
    key.last_used_time_ms = now_ms;
    *persist_last_used = key.id;
  }
  return VerifiedApiKey{
      .id = key.id,
      .user = key.user,
      .role = role.ok() ? *role : Role::kNone,
      .expire_time = absl::FromUnixMillis(key.expire_time_ms)};
}

void ApiKeyStore::PersistLastUsed(const std::string& id, absl::Time now) {
  if (id.empty()) return;
  if (absl::Status s = repository_.SetLastUsed(id, absl::ToUnixMillis(now));
      !s.ok()) {
    spdlog::warn("API key {}: cannot record its last use: {}", id,
                 std::string(s.message()));
  }
}

absl::StatusOr<VerifiedApiKey> ApiKeyStore::Active(absl::string_view id) {
  const absl::Time now = clock_();
  std::string persist_last_used;
  VerifiedApiKey verified;
  {
    absl::MutexLock lock(&mutex_);
    auto it = keys_.find(id);
    if (it == keys_.end()) {
      return absl::UnauthenticatedError(
          absl::StrCat("API key ", id, " is unknown"));
    }
    ASSIGN_OR_RETURN(verified, Use(it->second, now, &persist_last_used));
  }
  PersistLastUsed(persist_last_used, now);
  return verified;
}

absl::StatusOr<VerifiedApiKey> ApiKeyStore::Verify(absl::string_view token) {
  const std::string id = ApiKeyIdOf(token);
  if (id.empty()) {
    return absl::UnauthenticatedError(
        "the authorization header holds no API key: expected \"Bearer "
        "hs_<id>_<secret>\" as `hdrstereo admin key create` printed it");
  }
  const absl::string_view secret =
      token.substr(kPrefix.size() + 2 * kIdBytes + 1);
  const absl::Time now = clock_();
  std::string persist_last_used;
  VerifiedApiKey verified;
  {
    absl::MutexLock lock(&mutex_);
    auto it = keys_.find(id);
    absl::StatusOr<std::string> digest =
        it == keys_.end()
            ? absl::NotFoundError("")
            : Digest(absl::HexStringToBytes(it->second.salt_hex), secret);
    const std::string expected =
        it == keys_.end() ? std::string()
                          : absl::HexStringToBytes(it->second.digest_hex);
    if (!digest.ok() || digest->size() != expected.size() ||
        CRYPTO_memcmp(digest->data(), expected.data(), expected.size()) != 0) {
      return absl::UnauthenticatedError(
          absl::StrCat("API key ", id,
                       " is unknown or its secret is wrong; ask an admin "
                       "for a key (hdrstereo admin key create)"));
    }
    ASSIGN_OR_RETURN(verified, Use(it->second, now, &persist_last_used));
  }
  PersistLastUsed(persist_last_used, now);
  return verified;
}

absl::StatusOr<store::ApiKeyRecord> ApiKeyStore::Revoke(absl::string_view id,
                                                        absl::string_view by) {
  // Under the lock, so that no call verifies the key between the database
  // and the cache.
  absl::MutexLock lock(&mutex_);
  ASSIGN_OR_RETURN(store::ApiKeyRecord revoked,
                   repository_.Revoke(id, absl::ToUnixMillis(clock_()), by));
  if (auto it = keys_.find(id); it != keys_.end()) {
    revoked.last_used_time_ms = it->second.last_used_time_ms;
    it->second = revoked;
  }
  return revoked;
}

std::vector<store::ApiKeyRecord> ApiKeyStore::List(absl::string_view user,
                                                   bool include_inactive) {
  const int64_t now_ms = absl::ToUnixMillis(clock_());
  std::vector<store::ApiKeyRecord> out;
  absl::MutexLock lock(&mutex_);
  for (const auto& [id, key] : keys_) {
    if (!user.empty() && key.user != user) continue;
    const bool active =
        !key.revoke_time_ms.has_value() && now_ms < key.expire_time_ms;
    if (active || include_inactive) out.push_back(key);
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return std::tie(a.create_time_ms, a.id) < std::tie(b.create_time_ms, b.id);
  });
  return out;
}

}  // namespace hdrstereo::rpc
