// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/notify/webhook_signing.h"

#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/kdf.h>
#include <openssl/rand.h>
#include <sys/stat.h>

#include <fstream>
#include <memory>
#include <sstream>
#include <system_error>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"

namespace hdrstereo::notify {
namespace {

namespace fs = std::filesystem;

constexpr size_t kKeyBytes = 32;
constexpr size_t kSaltBytes = 16;
constexpr absl::string_view kSecretPrefix = "whsec_";
constexpr absl::string_view kHkdfInfo = "hdrstereo webhook secret v1";

absl::StatusOr<std::string> RandomBytes(size_t count) {
  std::string raw(count, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(raw.data()),
                 static_cast<int>(raw.size())) != 1) {
    return absl::InternalError("OpenSSL RAND_bytes failed");
  }
  return raw;
}

bool IsLowerHex(absl::string_view text) {
  for (char c : text) {
    if (!absl::ascii_isdigit(c) && (c < 'a' || c > 'f')) return false;
  }
  return true;
}

struct PkeyCtxDeleter {
  void operator()(EVP_PKEY_CTX* ctx) const { EVP_PKEY_CTX_free(ctx); }
};

}  // namespace

absl::StatusOr<WebhookSigner> WebhookSigner::Open(const fs::path& data_root) {
  const fs::path dir = data_root / "keys";
  const fs::path path = dir / "webhook-signing.key";
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    return absl::FailedPreconditionError(
        absl::StrCat("cannot create ", dir.string(), ": ", ec.message()));
  }
  // The folder keeps others out even of a file being written.
  fs::permissions(dir, fs::perms::owner_all, ec);
  if (ec) {
    return absl::FailedPreconditionError(absl::StrCat(
        "cannot make ", dir.string(), " mode 0700: ", ec.message()));
  }
  if (!fs::exists(path, ec)) {
    ASSIGN_OR_RETURN(std::string key, RandomBytes(kKeyBytes));
    RETURN_IF_ERROR(io::WriteFileAtomically(
        path, absl::StrCat(absl::BytesToHexString(key), "\n")));
    fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write, ec);
    if (ec) {
      return absl::FailedPreconditionError(absl::StrCat(
          "cannot make ", path.string(), " mode 0600: ", ec.message()));
    }
  }
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("cannot read ", path.string()));
  }
  if ((info.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    return absl::FailedPreconditionError(
        absl::StrCat(path.string(),
                     " is readable by others; chmod 600 it (and consider "
                     "its webhook secrets leaked: delete and re-create the "
                     "hooks after replacing it)"));
  }
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const std::string hex(absl::StripAsciiWhitespace(text.str()));
  if (!in || hex.size() != 2 * kKeyBytes || !IsLowerHex(hex)) {
    return absl::FailedPreconditionError(absl::StrCat(
        path.string(), " is not a signing key (", 2 * kKeyBytes,
        " lowercase hex digits); move it away and restart to make a new one "
        "(existing hooks then need re-creating)"));
  }
  return WebhookSigner(absl::HexStringToBytes(hex));
}

absl::StatusOr<std::string> WebhookSigner::NewSalt() {
  ASSIGN_OR_RETURN(std::string salt, RandomBytes(kSaltBytes));
  return absl::BytesToHexString(salt);
}

absl::StatusOr<std::string> WebhookSigner::SecretFor(
    absl::string_view salt_hex) const {
  if (salt_hex.size() != 2 * kSaltBytes || !IsLowerHex(salt_hex)) {
    return absl::DataLossError("a webhook's salt is not 32 hex digits");
  }
  const std::string salt = absl::HexStringToBytes(salt_hex);
  std::unique_ptr<EVP_PKEY_CTX, PkeyCtxDeleter> ctx(
      EVP_PKEY_CTX_new_id(EVP_PKEY_HKDF, nullptr));
  unsigned char out[kKeyBytes];
  size_t length = sizeof(out);
  const auto* salt_bytes = reinterpret_cast<const unsigned char*>(salt.data());
  const auto* key_bytes = reinterpret_cast<const unsigned char*>(key_.data());
  const auto* info_bytes =
      reinterpret_cast<const unsigned char*>(kHkdfInfo.data());
  const bool ok =
      ctx != nullptr && EVP_PKEY_derive_init(ctx.get()) == 1 &&
      EVP_PKEY_CTX_set_hkdf_md(ctx.get(), EVP_sha256()) == 1 &&
      EVP_PKEY_CTX_set1_hkdf_salt(ctx.get(), salt_bytes,
                                  static_cast<int>(salt.size())) == 1 &&
      EVP_PKEY_CTX_set1_hkdf_key(ctx.get(), key_bytes,
                                 static_cast<int>(key_.size())) == 1 &&
      EVP_PKEY_CTX_add1_hkdf_info(ctx.get(), info_bytes,
                                  static_cast<int>(kHkdfInfo.size())) == 1 &&
      EVP_PKEY_derive(ctx.get(), out, &length) == 1 && length == sizeof(out);
  if (!ok) return absl::InternalError("OpenSSL HKDF failed");
  return absl::StrCat(kSecretPrefix,
                      absl::BytesToHexString(absl::string_view(
                          reinterpret_cast<const char*>(out), sizeof(out))));
}

absl::StatusOr<std::string> SignatureHeaderValue(absl::string_view secret,
                                                 absl::string_view body) {
  unsigned char mac[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (HMAC(EVP_sha256(), secret.data(), static_cast<int>(secret.size()),
           reinterpret_cast<const unsigned char*>(body.data()), body.size(),
           mac, &length) == nullptr) {
    return absl::InternalError("OpenSSL HMAC-SHA256 failed");
  }
  return absl::StrCat("sha256=",
                      absl::BytesToHexString(absl::string_view(
                          reinterpret_cast<const char*>(mac), length)));
}

}  // namespace hdrstereo::notify
