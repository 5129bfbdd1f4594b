// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/server_credentials.h"

#include <grpcpp/security/tls_certificate_provider.h>
#include <grpcpp/security/tls_credentials_options.h>
#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::rpc {
namespace {

namespace fs = std::filesystem;

struct BioFree {
  void operator()(BIO* bio) const { BIO_free(bio); }
};
struct X509Free {
  void operator()(X509* x) const { X509_free(x); }
};
struct KeyFree {
  void operator()(EVP_PKEY* key) const { EVP_PKEY_free(key); }
};

std::string Name(const char* option, const fs::path& path) {
  return absl::StrCat(option, " ", path.string());
}

absl::StatusOr<std::string> ReadPem(const char* option, const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::InvalidArgumentError(absl::StrCat(
        Name(option, path), ": cannot read it (", std::strerror(errno), ")"));
  }
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::unique_ptr<BIO, BioFree> Bio(const std::string& pem) {
  return std::unique_ptr<BIO, BioFree>(
      BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())));
}

// The first certificate of a PEM text; null if there is none.
std::unique_ptr<X509, X509Free> FirstCertificate(const std::string& pem) {
  std::unique_ptr<BIO, BioFree> bio = Bio(pem);
  ERR_clear_error();
  return std::unique_ptr<X509, X509Free>(
      PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr));
}

absl::Status NotAfterNow(const char* option, const fs::path& path, X509* x) {
  if (X509_cmp_current_time(X509_get0_notAfter(x)) < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(Name(option, path),
                     ": the certificate has expired; make a new one "
                     "(deploy/make-certs.sh)"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<TlsMaterial> LoadTlsMaterial(const daemon::TlsConfig& tls) {
  TlsMaterial out;
  ASSIGN_OR_RETURN(out.cert_chain, ReadPem("--tls-cert", tls.cert));
  ASSIGN_OR_RETURN(out.private_key, ReadPem("--tls-key", tls.key));
  ASSIGN_OR_RETURN(out.client_ca, ReadPem("--tls-client-ca", tls.client_ca));

  std::unique_ptr<X509, X509Free> cert = FirstCertificate(out.cert_chain);
  if (cert == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        Name("--tls-cert", tls.cert),
        " holds no PEM certificate (-----BEGIN CERTIFICATE-----)"));
  }
  RETURN_IF_ERROR(NotAfterNow("--tls-cert", tls.cert, cert.get()));

  struct stat st {};
  if (::stat(tls.key.c_str(), &st) == 0 && (st.st_mode & S_IROTH) != 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        Name("--tls-key", tls.key),
        " is readable by every user on this machine; chmod o-r it (0640, "
        "group hdrstereo, as deploy/install.sh installs it)"));
  }
  std::unique_ptr<BIO, BioFree> key_bio = Bio(out.private_key);
  std::unique_ptr<EVP_PKEY, KeyFree> key(
      PEM_read_bio_PrivateKey(key_bio.get(), nullptr, nullptr, nullptr));
  if (key == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat(Name("--tls-key", tls.key),
                     " holds no PEM private key (an encrypted key is not "
                     "supported: hdrstereod starts unattended)"));
  }
  if (X509_check_private_key(cert.get(), key.get()) != 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        Name("--tls-key", tls.key), " does not match the certificate in ",
        Name("--tls-cert", tls.cert)));
  }

  std::unique_ptr<X509, X509Free> ca = FirstCertificate(out.client_ca);
  if (ca == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        Name("--tls-client-ca", tls.client_ca),
        " holds no PEM certificate: it must be the lab CA's certificate "
        "(ca.pem of deploy/make-certs.sh)"));
  }
  RETURN_IF_ERROR(NotAfterNow("--tls-client-ca", tls.client_ca, ca.get()));

  if (!tls.crl_dir.empty()) {
    std::error_code ec;
    if (!fs::is_directory(tls.crl_dir, ec)) {
      return absl::InvalidArgumentError(
          absl::StrCat(Name("--tls-crl-dir", tls.crl_dir), " is not a folder"));
    }
    out.crl_dir = tls.crl_dir.string();
  }
  ERR_clear_error();
  return out;
}

std::shared_ptr<grpc::ServerCredentials> TlsCredentials(
    const TlsMaterial& tls) {
  auto provider =
      std::make_shared<grpc::experimental::StaticDataCertificateProvider>(
          tls.client_ca, std::vector<grpc::experimental::IdentityKeyCertPair>{
                             {tls.private_key, tls.cert_chain}});
  grpc::experimental::TlsServerCredentialsOptions options(provider);
  options.watch_root_certs();
  options.watch_identity_key_cert_pairs();
  // Requested, and verified when presented: a call without a certificate
  // may still authenticate with an API key.
  options.set_cert_request_type(GRPC_SSL_REQUEST_CLIENT_CERTIFICATE_AND_VERIFY);
  if (!tls.crl_dir.empty()) options.set_crl_directory(tls.crl_dir);
  return grpc::experimental::TlsServerCredentials(options);
}

std::shared_ptr<grpc::ServerCredentials> ServerCredentialsFor(
    const std::string& address, const TlsMaterial* tls,
    std::shared_ptr<grpc::AuthMetadataProcessor> guard) {
  std::shared_ptr<grpc::ServerCredentials> credentials =
      daemon::IsLocalAddress(address) || tls == nullptr
          ? grpc::experimental::LocalServerCredentials(
                absl::StartsWith(address, "unix:") ? UDS : LOCAL_TCP)
          : TlsCredentials(*tls);
  credentials->SetAuthMetadataProcessor(std::move(guard));
  return credentials;
}

}  // namespace hdrstereo::rpc
