// SPDX-License-Identifier: GPL-3.0-or-later
//
// The client.toml profile file: its fixed shape, unknown keys refused by
// name, and the limits on what a file may hold.
#include "clients/cli/profile_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::cli {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

TEST(ProfileFileTest, ReadsTheDocumentedShape) {
  ASSERT_OK_AND_ASSIGN(ProfileFile file, ParseProfileFile("client.toml", R"(
# my lab
default_profile = "lab"   # used when no --profile is given

[profile.lab]
server = "labpc.example.org:50051"
tls_ca = "/home/alice/.config/hdrstereo/lab-ca.pem"
tls_cert = "alice.pem"
tls_key = "alice.key"

[profile.notebook]
server = "labpc:50051"
tls_ca = "ca.pem"
api_key_file = "with \"quotes\" and # hash"
)"));
  EXPECT_EQ(file.default_profile, "lab");
  ASSERT_EQ(file.profiles.size(), 2u);
  EXPECT_EQ(file.profiles["lab"].server, "labpc.example.org:50051");
  EXPECT_EQ(file.profiles["lab"].tls_ca,
            "/home/alice/.config/hdrstereo/lab-ca.pem");
  EXPECT_EQ(file.profiles["lab"].tls_key, "alice.key");
  EXPECT_EQ(file.profiles["notebook"].api_key_file,
            "with \"quotes\" and # hash");
}

TEST(ProfileFileTest, RefusesWhatItDoesNotKnowByName) {
  EXPECT_THAT(ParseProfileFile("c.toml", "[profile.lab]\ntls_crt = \"x\"\n"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c.toml:2: unknown key \"tls_crt\" in "
                                 "section \"profile.lab\"")));
  EXPECT_THAT(ParseProfileFile("c.toml", "server = \"x\"\n"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c.toml:1: unknown key \"server\"")));
  EXPECT_THAT(ParseProfileFile("c.toml", "[lab]\n"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c.toml:1: unknown section \"lab\"; "
                                 "profiles are [profile.NAME]")));
  EXPECT_THAT(
      ParseProfileFile("c.toml", "[profile.a]\nserver = x\n"),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("quoted string")));
  EXPECT_THAT(ParseProfileFile("c.toml",
                               "[profile.a]\nserver = \"x\"\nserver = \"y\"\n"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c.toml:3: server is set twice")));
  EXPECT_THAT(ParseProfileFile("c.toml", "[profile.a]\n[profile.a]\n"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c.toml:2: section \"profile.a\" appears "
                                 "twice")));
  EXPECT_THAT(ParseProfileFile("c.toml", "default_profile = \"b\"\n"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c.toml: default_profile \"b\" has no "
                                 "section \"profile.b\"")));
}

TEST(ProfileFileTest, LimitsTheFileAndItsLines) {
  const std::string big(kMaxProfileFileBytes + 1, '#');
  EXPECT_THAT(ParseProfileFile("c.toml", big),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c.toml: the file is 1048577 bytes; the most "
                                 "is 1048576")));
  // A line as long as the limit is read; one byte more is refused.
  const std::string path(kMaxProfileLineBytes - 11, 'p');
  ASSERT_OK_AND_ASSIGN(
      ProfileFile file,
      ParseProfileFile("c.toml", "[profile.a]\ntls_ca = \"" + path + "\"\n"));
  EXPECT_EQ(file.profiles["a"].tls_ca, path);
  EXPECT_THAT(
      ParseProfileFile("c.toml", "[profile.a]\ntls_ca = \"" + path + "p\"\n"),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("c.toml:2: the line is 8193 bytes long; the most is "
                         "8192")));

  testing::TempDir dir;
  const std::string name = (dir / "client.toml").string();
  std::ofstream(name) << big;
  // Refused by its size before it is read, not by the parser's check.
  EXPECT_THAT(LoadProfileFile(name),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       name + ": profile file of 1048577 bytes, more than the "
                              "limit of 1048576; not read"));
  EXPECT_THAT(LoadProfileFile(dir / "none.toml"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "cannot open " + (dir / "none.toml").string() +
                           ": No such file or directory"));
}

// What the file holds is repeated in messages as a bounded, escaped prefix.
TEST(ProfileFileTest, MessagesQuoteABoundedPrefix) {
  const std::string key(5000, 'k');
  absl::StatusOr<ProfileFile> file =
      ParseProfileFile("c.toml", "[profile.a]\n" + key + " = \"x\"\n");
  EXPECT_THAT(file, StatusIs(absl::StatusCode::kInvalidArgument,
                             HasSubstr("... (5000 bytes) in section "
                                       "\"profile.a\"")));
  EXPECT_LT(file.status().message().size(), 300u);
  EXPECT_THAT(ParseProfileFile("c.toml", "[profile.a]\nse\x01rver = \"x\"\n" +
                                             std::string("\0\xff", 2)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("unknown key \"se\\x01rver\""),
                             Not(HasSubstr("\x01")))));
}

// Section names, keys and the default profile reach messages escaped and
// bounded: no control character of the file reaches the terminal.
TEST(ProfileFileTest, MessagesEscapeSectionsKeysAndTheDefaultProfile) {
  const struct {
    std::string text;
    std::string message;
  } cases[] = {
      {"[\x1b[2J]\n", "c.toml:1: unknown section \"\\x1b[2J\""},
      {"[profile.\x1b]\n[profile.\x1b]\n",
       "c.toml:2: section \"profile.\\x1b\" appears twice"},
      {"[profile.a]\nk\a = x\n",
       "c.toml:2: \"k\\x07\": the value must be a \"quoted string\""},
      {"[profile.\x1b]\nport = \"1\"\n",
       "c.toml:2: unknown key \"port\" in section \"profile.\\x1b\""},
      {"default_profile = \"\x1b[2J\"\n",
       "c.toml: default_profile \"\\x1b[2J\" has no section "
       "\"profile.\\x1b[2J\""},
  };
  for (const auto& [text, message] : cases) {
    EXPECT_THAT(ParseProfileFile("c.toml", text),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         AllOf(HasSubstr(message), Not(HasSubstr("\x1b")),
                               Not(HasSubstr("\a")))))
        << text;
  }
  const absl::StatusOr<ProfileFile> file =
      ParseProfileFile("c.toml", "[" + std::string(5000, 'n') + "]\n");
  EXPECT_THAT(file, StatusIs(absl::StatusCode::kInvalidArgument,
                             HasSubstr("\"... (5000 bytes); profiles are")));
  EXPECT_LT(file.status().message().size(), 300u);
}

}  // namespace
}  // namespace hdrstereo::cli
