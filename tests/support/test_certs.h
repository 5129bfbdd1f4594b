// SPDX-License-Identifier: GPL-3.0-or-later
//
// Real certificates for tests, made once per test program by
// deploy/make-certs.sh (openssl only) in a temporary folder: a lab CA, the
// server (SANs localhost, 127.0.0.1 and this host's name), clients alice,
// bob, carol, dave and erin, an expired one (expired, with explicit dates
// in 2020), a not yet valid one (future, 2099), a revoked one (revoked,
// in the CA's CRL), and a rogue CA with one client (mallory).
#ifndef HDRSTEREO_TESTS_SUPPORT_TEST_CERTS_H_
#define HDRSTEREO_TESTS_SUPPORT_TEST_CERTS_H_

#include <filesystem>
#include <string>
#include <vector>

#include "tests/support/temp_dir.h"

namespace hdrstereo::testing {

class TestCerts {
 public:
  // Made at the first call; fails the test (and returns a folder without
  // files) when openssl or the script fails.
  static const TestCerts& Get();

  std::filesystem::path lab_dir() const { return dir_.path() / "lab"; }
  std::filesystem::path rogue_dir() const { return dir_.path() / "rogue"; }
  std::filesystem::path ca() const { return lab_dir() / "ca.pem"; }
  std::filesystem::path server_cert() const { return lab_dir() / "server.pem"; }
  std::filesystem::path server_key() const { return lab_dir() / "server.key"; }
  std::filesystem::path crl_dir() const { return lab_dir() / "crl"; }
  std::filesystem::path rogue_ca() const { return rogue_dir() / "ca.pem"; }
  std::filesystem::path Cert(const std::string& user) const;
  std::filesystem::path Key(const std::string& user) const;

  // The daemon options for TLS with these files and the users' roles:
  // alice viewer, bob operator, carol admin, erin operator (and operator
  // for expired, future, revoked, so that only their certificates fail);
  // dave and mallory have no role.
  std::vector<std::string> DaemonArgs() const;
  // CLI options to connect as `user` with its certificate.
  std::vector<std::string> CliArgs(const std::string& user) const;

 private:
  TestCerts();
  TempDir dir_;
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_TEST_CERTS_H_
