// SPDX-License-Identifier: GPL-3.0-or-later
//
// Webhook signatures. Each hook's secret is derived (HKDF-SHA256, OpenSSL)
// from the data root's signing key and a random salt stored with the hook,
// so the database holds no secret: the key lives in <data root>/keys/
// (folder 0700, file 0600) and a copy of the database alone cannot forge a
// signature. The secret is shown to the admin once, when the hook is
// created; the receiver checks
//   X-Hdrstereo-Signature: sha256=<hex HMAC-SHA256(secret, body)>.
#ifndef HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_SIGNING_H_
#define HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_SIGNING_H_

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::notify {

class WebhookSigner {
 public:
  // Reads <data_root>/keys/webhook-signing.key, creating it (32 random
  // bytes) on first use. FAILED_PRECONDITION when it is unreadable,
  // malformed, or readable by others.
  static absl::StatusOr<WebhookSigner> Open(
      const std::filesystem::path& data_root);

  // A fresh random salt (hex) for a new hook.
  static absl::StatusOr<std::string> NewSalt();
  // The hook's secret: "whsec_" + 64 hex digits.
  absl::StatusOr<std::string> SecretFor(absl::string_view salt_hex) const;

 private:
  explicit WebhookSigner(std::string key) : key_(std::move(key)) {}
  std::string key_;  // raw bytes
};

// "sha256=" + hex HMAC-SHA256 of `body` keyed with `secret` (its bytes as
// shown to the admin).
absl::StatusOr<std::string> SignatureHeaderValue(absl::string_view secret,
                                                 absl::string_view body);

}  // namespace hdrstereo::notify

#endif  // HDRSTEREO_DAEMON_NOTIFY_WEBHOOK_SIGNING_H_
