// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/test_certs.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include "absl/strings/str_cat.h"
#include "tests/support/subprocess.h"

namespace hdrstereo::testing {
namespace {

namespace fs = std::filesystem;

void MakeCerts(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {std::string(HDRSTEREO_SOURCE_DIR) +
                                   "/deploy/make-certs.sh"};
  argv.insert(argv.end(), args.begin(), args.end());
  absl::StatusOr<CommandResult> result = RunCommand(argv, absl::Seconds(60));
  ASSERT_TRUE(result.ok()) << result.status();
  ASSERT_EQ(result->exit_code, 0) << result->err;
}

std::string HostName() {
  char name[256] = {};
  ::gethostname(name, sizeof name - 1);
  return name;
}

}  // namespace

const TestCerts& TestCerts::Get() {
  static const TestCerts certs;  // its folder goes when the program ends
  return certs;
}

TestCerts::TestCerts() {
  const std::string lab = lab_dir().string();
  const std::string rogue = rogue_dir().string();
  MakeCerts({lab, "ca"});
  MakeCerts({lab, "server", "localhost", "127.0.0.1", HostName()});
  for (const char* user :
       {"alice", "bob", "carol", "dave", "erin", "revoked"}) {
    MakeCerts({lab, "client", user});
  }
  MakeCerts({lab, "client", "expired", "--start", "20200101000000Z", "--end",
             "20200102000000Z"});
  MakeCerts({lab, "client", "future", "--start", "20990101000000Z", "--end",
             "20991231000000Z"});
  MakeCerts({lab, "revoke", "revoked"});
  MakeCerts({rogue, "ca"});
  MakeCerts({rogue, "client", "mallory"});
}

fs::path TestCerts::Cert(const std::string& user) const {
  return (user == "mallory" ? rogue_dir() : lab_dir()) / (user + ".pem");
}

fs::path TestCerts::Key(const std::string& user) const {
  return (user == "mallory" ? rogue_dir() : lab_dir()) / (user + ".key");
}

std::vector<std::string> TestCerts::DaemonArgs() const {
  return {"--tls-cert",          server_cert().string(), "--tls-key",
          server_key().string(), "--tls-client-ca",      ca().string(),
          "--tls-crl-dir",       crl_dir().string(),     "--auth-user",
          "alice=viewer",        "--auth-user",          "bob=operator",
          "--auth-user",         "carol=admin",          "--auth-user",
          "erin=operator",       "--auth-user",          "expired=operator",
          "--auth-user",         "future=operator",      "--auth-user",
          "revoked=operator"};
}

std::vector<std::string> TestCerts::CliArgs(const std::string& user) const {
  return {"--tls-ca",          ca().string(), "--tls-cert",
          Cert(user).string(), "--tls-key",   Key(user).string()};
}

}  // namespace hdrstereo::testing
