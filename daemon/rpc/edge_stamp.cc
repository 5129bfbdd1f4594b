// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/edge_stamp.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>

#include <iterator>
#include <optional>
#include <vector>

#include "absl/strings/escaping.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::rpc {
namespace {

constexpr size_t kSecretBytes = 32;
// The caller field as the edge writes it: five web-safe base64 fields
// (name, role, auth_method, peer, key expiry) of at most 64 + 8 + 64 + 256
// + 20 bytes, 4/3 larger encoded, and the dots between them: well under
// this, which bounds what is decoded or hashed for a call.
constexpr size_t kMaxCallerBytes = 1024;
constexpr size_t kMaxAuthMethodBytes = 64;
constexpr size_t kMaxPeerBytes = 256;

using Metadata = std::multimap<grpc::string_ref, grpc::string_ref>;

// The one value of `key`: nullopt when absent; UNAUTHENTICATED when given
// more than once (which one would count is not for the guard to guess).
absl::StatusOr<std::optional<absl::string_view>> OneValue(
    const Metadata& metadata, const char* key) {
  auto [begin, end] = metadata.equal_range(key);
  if (begin == end) return std::nullopt;
  if (std::next(begin) != end) {
    return absl::UnauthenticatedError(
        absl::StrCat("the call carries ", key, " more than once"));
  }
  return absl::string_view(begin->second.data(), begin->second.size());
}

// HMAC-SHA256 of the caller field under the boot's secret, hex.
std::string Mac(absl::string_view secret, absl::string_view caller) {
  unsigned char mac[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (HMAC(EVP_sha256(), secret.data(), static_cast<int>(secret.size()),
           reinterpret_cast<const unsigned char*>(caller.data()), caller.size(),
           mac, &size) == nullptr) {
    return "";  // matches no stamp: Verify refuses
  }
  return absl::BytesToHexString(
      absl::string_view(reinterpret_cast<const char*>(mac), size));
}

// Printable ASCII without spaces, 1 to `max_bytes` long.
absl::Status CheckToken(absl::string_view field, absl::string_view value,
                        size_t max_bytes) {
  if (value.empty() || value.size() > max_bytes) {
    return absl::UnauthenticatedError(
        absl::StrCat("the stamped caller's ", field, " has ", value.size(),
                     " bytes; it must have 1 to ", max_bytes));
  }
  for (char c : value) {
    if (c <= ' ' || c > '~') {
      return absl::UnauthenticatedError(
          absl::StrCat("the stamped caller's ", field, " ", QuoteInput(value),
                       " holds a space or a byte that is not printable ASCII"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<EdgeCaller> ParseCaller(absl::string_view field) {
  const std::vector<absl::string_view> parts = absl::StrSplit(field, '.');
  std::vector<std::string> values(parts.size());
  bool decoded = parts.size() == 5;
  for (size_t i = 0; decoded && i < parts.size(); ++i) {
    decoded = absl::WebSafeBase64Unescape(parts[i], &values[i]);
  }
  if (!decoded) {
    return absl::UnauthenticatedError(
        "the x-hdrstereo-edge-caller field is not five web-safe base64 "
        "fields (name.role.auth_method.peer.key_expiry)");
  }
  EdgeCaller caller;
  caller.principal.name = values[0];
  if (absl::Status s =
          ValidatePrincipalName(values[0], "the stamped caller's name");
      !s.ok()) {
    return absl::UnauthenticatedError(s.message());
  }
  absl::StatusOr<Role> role = ParseRole(values[1]);
  if (!role.ok()) {
    return absl::UnauthenticatedError(
        absl::StrCat("the stamped caller's role: ", role.status().message()));
  }
  caller.principal.role = *role;
  RETURN_IF_ERROR(CheckToken("auth_method", values[2], kMaxAuthMethodBytes));
  caller.principal.auth_method = values[2];
  RETURN_IF_ERROR(CheckToken("peer", values[3], kMaxPeerBytes));
  caller.peer = values[3];
  if (!values[4].empty()) {
    int64_t ms = 0;
    if (!absl::SimpleAtoi(values[4], &ms)) {
      return absl::UnauthenticatedError(
          absl::StrCat("the stamped caller's key expiry ",
                       QuoteInput(values[4]), " is not Unix milliseconds"));
    }
    caller.principal.key_expire_time = absl::FromUnixMillis(ms);
  }
  return caller;
}

}  // namespace

absl::StatusOr<EdgeStamp> EdgeStamp::Create() {
  std::string secret(kSecretBytes, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(secret.data()),
                 static_cast<int>(secret.size())) != 1) {
    return absl::InternalError("OpenSSL RAND_bytes failed");
  }
  return EdgeStamp(std::move(secret));
}

void EdgeStamp::Apply(const EdgeCaller& caller,
                      grpc::ClientContext& context) const {
  const Principal& p = caller.principal;
  const std::string field = absl::StrJoin(
      {absl::WebSafeBase64Escape(p.name),
       absl::WebSafeBase64Escape(RoleName(p.role)),
       absl::WebSafeBase64Escape(p.auth_method),
       absl::WebSafeBase64Escape(caller.peer),
       absl::WebSafeBase64Escape(
           p.key_expire_time.has_value()
               ? absl::StrCat(absl::ToUnixMillis(*p.key_expire_time))
               : "")},
      ".");
  context.AddMetadata(kEdgeStampKey, Mac(secret_, field));
  context.AddMetadata(kEdgeCallerKey, field);
}

absl::StatusOr<EdgeCaller> EdgeStamp::Verify(const Metadata& metadata) const {
  ASSIGN_OR_RETURN(std::optional<absl::string_view> stamp,
                   OneValue(metadata, kEdgeStampKey));
  ASSIGN_OR_RETURN(std::optional<absl::string_view> caller,
                   OneValue(metadata, kEdgeCallerKey));
  if (!stamp.has_value()) {
    return absl::UnauthenticatedError(
        "an in-process call needs the stamp of hdrstereod's HTTP edge, and "
        "this one carries no x-hdrstereo-edge-stamp");
  }
  if (!caller.has_value()) {
    return absl::UnauthenticatedError(
        "the call carries an x-hdrstereo-edge-stamp but no "
        "x-hdrstereo-edge-caller naming whom it vouches for");
  }
  if (caller->size() > kMaxCallerBytes) {
    return absl::UnauthenticatedError(
        absl::StrCat("the x-hdrstereo-edge-caller field has ", caller->size(),
                     " bytes, more than the limit of ", kMaxCallerBytes));
  }
  const std::string expected = Mac(secret_, *caller);
  if (expected.empty() || stamp->size() != expected.size() ||
      CRYPTO_memcmp(stamp->data(), expected.data(), expected.size()) != 0) {
    return absl::UnauthenticatedError(
        "the x-hdrstereo-edge-stamp does not vouch for this caller: it is "
        "not this boot's HTTP edge's, or the caller field was altered");
  }
  return ParseCaller(*caller);
}

bool HasEdgeStamp(const Metadata& metadata) {
  return metadata.count(kEdgeStampKey) > 0 ||
         metadata.count(kEdgeCallerKey) > 0;
}

}  // namespace hdrstereo::rpc
