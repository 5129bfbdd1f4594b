// SPDX-License-Identifier: GPL-3.0-or-later
//
// The shipped deployment files: the sample config parses with hdrstereod's
// own parser, an unknown key is refused by name, every option of the
// parser is documented in it, and the systemd unit passes
// `systemd-analyze verify` (offline; skipped where systemd-analyze is not
// installed).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "daemon/config.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo {
namespace {

using ::testing::HasSubstr;

const std::string kSource = HDRSTEREO_SOURCE_DIR;

std::string Read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

absl::StatusOr<daemon::ParsedArgs> Parse(std::vector<std::string> args) {
  args.insert(args.begin(), "hdrstereod");
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  return daemon::ParseArgs(static_cast<int>(argv.size()), argv.data());
}

TEST(DeployTest, ShippedConfigIsAccepted) {
  absl::StatusOr<daemon::ParsedArgs> parsed =
      Parse({"--config", kSource + "/deploy/config/hdrstereod.toml"});
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  const auto& config = std::get<daemon::Config>(*parsed);
  EXPECT_EQ(config.data_root, "/var/lib/hdrstereo");
  EXPECT_EQ(config.hardware, "real");
  EXPECT_EQ(config.stage_port, "/dev/hdrstereo-stage");
  EXPECT_EQ(config.listen, "127.0.0.1:50051");
}

TEST(DeployTest, UnknownConfigKeyIsRefusedByName) {
  testing::TempDir dir;
  const std::string path = (dir / "bad.toml").string();
  std::ofstream(path) << Read(kSource + "/deploy/config/hdrstereod.toml")
                      << "\nstage-prot = \"/dev/ttyUSB1\"\n";
  absl::StatusOr<daemon::ParsedArgs> parsed = Parse({"--config", path});
  ASSERT_FALSE(parsed.ok());
  EXPECT_THAT(std::string(parsed.status().message()), HasSubstr("stage-prot"));
}

TEST(DeployTest, EveryOptionIsDocumentedInTheShippedConfig) {
  absl::StatusOr<daemon::ParsedArgs> help = Parse({"--help"});
  ASSERT_TRUE(help.ok());
  const std::string text = std::get<daemon::ExitWithText>(*help).text;
  const std::string toml = Read(kSource + "/deploy/config/hdrstereod.toml");
  std::istringstream lines(text);
  std::string line;
  int options = 0;
  while (std::getline(lines, line)) {
    const size_t dashes = line.find("--");
    if (dashes == std::string::npos) continue;
    const std::string name =
        line.substr(dashes + 2, line.find_first_of(" =", dashes) - dashes - 2);
    if (name == "help" || name == "version" || name == "config") continue;
    ++options;
    EXPECT_THAT(toml, HasSubstr(absl::StrCat(name, " = "))) << name;
  }
  EXPECT_GT(options, 20);
}

TEST(DeployTest, SystemdUnitVerifies) {
  if (std::system("command -v systemd-analyze >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "systemd-analyze is not installed";
  }
  // verify checks that ExecStart exists: point it at the built daemon.
  testing::TempDir dir;
  const std::string unit = (dir / "hdrstereod.service").string();
  std::ofstream(unit) << absl::StrReplaceAll(
      Read(kSource + "/deploy/systemd/hdrstereod.service"),
      {{"/usr/local/bin/hdrstereod", HDRSTEREOD}});
  absl::StatusOr<testing::CommandResult> result = testing::RunCommand(
      {"/bin/sh", "-c", absl::StrCat("systemd-analyze verify --man=no ", unit)},
      absl::Seconds(60));
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->exit_code, 0) << result->out << result->err;
  EXPECT_EQ(result->err, "") << "warnings from systemd-analyze verify";
}

}  // namespace
}  // namespace hdrstereo
