// SPDX-License-Identifier: GPL-3.0-or-later
//
// The CLI's connection settings: the precedence option > environment >
// profile > default, paths relative to the profile file, and the refusal of
// secrets that others can read or that would travel without TLS (the
// profile file itself: profile_file_test.cc).
#include "clients/cli/connection.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <map>

#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::cli {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

constexpr char kKey[] =
    "hs_0123456789ab_"
    "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef";

class ResolveTest : public ::testing::Test {
 protected:
  void Write(const std::string& name, const std::string& text,
             mode_t mode = 0600) {
    const fs::path path = dir_ / name;
    fs::create_directories(path.parent_path());
    std::ofstream(path) << text;
    ::chmod(path.c_str(), mode);
  }
  absl::StatusOr<Connection> Resolve(const ConnectionOptions& flags = {}) {
    return ResolveConnection(flags, [this](const char* name) -> const char* {
      auto it = env_.find(name);
      return it == env_.end() ? nullptr : it->second.c_str();
    });
  }

  testing::TempDir dir_;
  std::map<std::string, std::string> env_ = {
      {"HOME", (dir_ / "home").string()}};
};

TEST_F(ResolveTest, DefaultsToTheLocalDaemonWithoutTls) {
  ASSERT_OK_AND_ASSIGN(Connection c, Resolve());
  EXPECT_EQ(c.server, "localhost:50051");
  EXPECT_FALSE(c.tls);
  EXPECT_EQ(c.profile, "");
}

TEST_F(ResolveTest, OptionBeatsEnvironmentBeatsProfile) {
  Write("home/.config/hdrstereo/client.toml",
        "default_profile = \"lab\"\n[profile.lab]\nserver = \"profile:1\"\n"
        "tls_ca = \"ca.pem\"\n");
  Write("home/.config/hdrstereo/ca.pem", "PROFILE CA", 0644);
  Write("env-ca.pem", "ENV CA", 0644);
  ASSERT_OK_AND_ASSIGN(Connection c, Resolve());
  EXPECT_EQ(c.profile, "lab");
  EXPECT_EQ(c.server, "profile:1");
  EXPECT_TRUE(c.tls);
  EXPECT_EQ(c.ca_pem, "PROFILE CA");  // relative to the file's folder

  env_["HDRSTEREO_SERVER"] = "env:2";
  env_["HDRSTEREO_TLS_CA"] = (dir_ / "env-ca.pem").string();
  ASSERT_OK_AND_ASSIGN(c, Resolve());
  EXPECT_EQ(c.server, "env:2");
  EXPECT_EQ(c.ca_pem, "ENV CA");

  ConnectionOptions flags;
  flags.server = "flag:3";
  ASSERT_OK_AND_ASSIGN(c, Resolve(flags));
  EXPECT_EQ(c.server, "flag:3");
}

TEST_F(ResolveTest, TheProfileIsChosenByOptionEnvironmentOrDefault) {
  Write("p.toml",
        "default_profile = \"a\"\n[profile.a]\nserver = \"a:1\"\n"
        "[profile.b]\nserver = \"b:1\"\n");
  env_["HDRSTEREO_CLIENT_CONFIG"] = (dir_ / "p.toml").string();
  ASSERT_OK_AND_ASSIGN(Connection c, Resolve());
  EXPECT_EQ(c.server, "a:1");
  env_["HDRSTEREO_PROFILE"] = "b";
  ASSERT_OK_AND_ASSIGN(c, Resolve());
  EXPECT_EQ(c.server, "b:1");
  ConnectionOptions flags;
  flags.profile = "a";
  ASSERT_OK_AND_ASSIGN(c, Resolve(flags));
  EXPECT_EQ(c.server, "a:1");
  flags.profile = "c";
  EXPECT_THAT(Resolve(flags), StatusIs(absl::StatusCode::kInvalidArgument,
                                       HasSubstr("no profile \"c\" in")));
  env_["HDRSTEREO_CLIENT_CONFIG"] = (dir_ / "missing.toml").string();
  EXPECT_THAT(Resolve(flags), StatusIs(absl::StatusCode::kInvalidArgument,
                                       HasSubstr("there is no")));
}

TEST_F(ResolveTest, SecretsReadableByOthersAreRefusedWithTheChmod) {
  Write("ca.pem", "CA", 0644);
  Write("alice.pem", "CERT", 0644);
  Write("alice.key", "KEY", 0640);
  ConnectionOptions flags;
  flags.tls_ca = (dir_ / "ca.pem").string();
  flags.tls_cert = (dir_ / "alice.pem").string();
  flags.tls_key = (dir_ / "alice.key").string();
  EXPECT_THAT(
      Resolve(flags),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("is readable by its group (mode 0640); make it yours "
                         "alone: chmod 600 " +
                         flags.tls_key)));
  ::chmod(flags.tls_key.c_str(), 0600);
  ASSERT_OK_AND_ASSIGN(Connection c, Resolve(flags));
  EXPECT_EQ(c.key_pem, "KEY");
  EXPECT_EQ(c.cert_pem, "CERT");

  ConnectionOptions keyed;
  keyed.tls_ca = flags.tls_ca;
  keyed.api_key_file = (dir_ / "key").string();
  Write("key", std::string(kKey) + "\n", 0644);
  EXPECT_THAT(Resolve(keyed),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("readable by other users (mode 0644); make "
                                 "it yours alone: chmod 600")));
  ::chmod(keyed.api_key_file.c_str(), 0600);
  ASSERT_OK_AND_ASSIGN(c, Resolve(keyed));
  EXPECT_EQ(c.api_key, kKey);
  Write("key", "not a key\n", 0600);
  EXPECT_THAT(Resolve(keyed), StatusIs(absl::StatusCode::kInvalidArgument,
                                       HasSubstr("does not hold one API key")));
}

TEST_F(ResolveTest, CredentialsWithoutTlsAreRefused) {
  Write("key", kKey, 0600);
  ConnectionOptions flags;
  flags.api_key_file = (dir_ / "key").string();
  EXPECT_THAT(Resolve(flags),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("an API key is only sent over TLS")));
  ConnectionOptions cert;
  cert.tls_cert = "a.pem";
  EXPECT_THAT(Resolve(cert), StatusIs(absl::StatusCode::kInvalidArgument,
                                      HasSubstr("go together")));
  cert.tls_key = "a.key";
  EXPECT_THAT(Resolve(cert),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("a client certificate is only sent over "
                                 "TLS")));
  ConnectionOptions ca;
  ca.tls_ca = (dir_ / "nope.pem").string();
  EXPECT_THAT(Resolve(ca), StatusIs(absl::StatusCode::kInvalidArgument,
                                    HasSubstr("cannot read --tls-ca")));
}

}  // namespace
}  // namespace hdrstereo::cli
