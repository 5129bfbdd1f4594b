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

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "daemon/config.h"
#include "tests/support/status_matchers.h"
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
  EXPECT_EQ(config.hardware, hardware::HardwareMode::kReal);
  EXPECT_EQ(config.stage_port, "/dev/hdrstereo-stage");
  EXPECT_THAT(config.listen,
              ::testing::ElementsAre("unix:/run/hdrstereo/hdrstereod.sock"));
  EXPECT_EQ(config.local_role, "admin");
  EXPECT_FALSE(config.tls.enabled());
}

TEST(DeployTest, TlsAndAuthSectionsBecomeTheirOptions) {
  testing::TempDir dir;
  const std::string path = (dir / "remote.toml").string();
  std::ofstream(path) << R"(listen = ["unix:/tmp/h.sock", "0.0.0.0:50051"]
[tls]
cert = "/etc/hdrstereo/tls/server.pem"
key = "/etc/hdrstereo/tls/server.key"
client-ca = "/etc/hdrstereo/tls/ca.pem"
crl-dir = "/etc/hdrstereo/tls/crl"
[auth]
local-role = "viewer"
[auth.users]
alice = "viewer"
bob = "operator"
)";
  absl::StatusOr<daemon::ParsedArgs> parsed = Parse({"--config", path});
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  const auto& config = std::get<daemon::Config>(*parsed);
  EXPECT_THAT(config.listen,
              ::testing::ElementsAre("unix:/tmp/h.sock", "0.0.0.0:50051"));
  EXPECT_EQ(config.tls.cert, "/etc/hdrstereo/tls/server.pem");
  EXPECT_EQ(config.tls.key, "/etc/hdrstereo/tls/server.key");
  EXPECT_EQ(config.tls.client_ca, "/etc/hdrstereo/tls/ca.pem");
  EXPECT_EQ(config.tls.crl_dir, "/etc/hdrstereo/tls/crl");
  EXPECT_EQ(config.local_role, "viewer");
  EXPECT_THAT(config.users, ::testing::UnorderedElementsAre(
                                ::testing::Pair("alice", "viewer"),
                                ::testing::Pair("bob", "operator")));
  // The command line still wins.
  parsed = Parse({"--config", path, "--tls-cert", "/other.pem"});
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_EQ(std::get<daemon::Config>(*parsed).tls.cert, "/other.pem");
}

TEST(DeployTest, ProcessingAndSlurmSectionsBecomeTheirOptions) {
  testing::TempDir dir;
  const std::string path = (dir / "cluster.toml").string();
  std::ofstream(path) << R"(data-root = "/srv/hdrstereo"
max-cluster-jobs = 40
[processing]
backend = "slurm"
threads = 3
[slurm]
partition = "short"
account = "lab"
cpus-per-task = 8
memory = "16G"
time-limit = "02:00:00"
extra-arg = ["--constraint=avx2", "--exclusive"]
proc-path = "/opt/hdrstereo/bin/hdrstereo-proc"
data-root = "/cluster/hdrstereo"
conf = "/etc/slurm-lab/slurm.conf"
poll-s = 2
)";
  absl::StatusOr<daemon::ParsedArgs> parsed = Parse({"--config", path});
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  const auto& config = std::get<daemon::Config>(*parsed);
  EXPECT_EQ(config.processing_backend, daemon::ProcessingBackend::kSlurm);
  EXPECT_EQ(config.processing_threads, 3);
  EXPECT_EQ(config.max_cluster_jobs, 40);
  EXPECT_EQ(config.slurm.partition, "short");
  EXPECT_EQ(config.slurm.account, "lab");
  EXPECT_EQ(config.slurm.cpus_per_task, 8);
  EXPECT_EQ(config.slurm.memory, "16G");
  EXPECT_EQ(config.slurm.time_limit, "02:00:00");
  EXPECT_THAT(config.slurm.extra_sbatch_args,
              ::testing::ElementsAre("--constraint=avx2", "--exclusive"));
  EXPECT_EQ(config.slurm.proc_path, "/opt/hdrstereo/bin/hdrstereo-proc");
  EXPECT_EQ(config.slurm.cluster_data_root, "/cluster/hdrstereo");
  EXPECT_EQ(config.slurm.local_data_root, "/srv/hdrstereo")
      << "the mapping starts at the daemon's data root";
  EXPECT_EQ(config.slurm.conf, "/etc/slurm-lab/slurm.conf");
  EXPECT_EQ(config.slurm.poll_s, 2);

  absl::StatusOr<daemon::ParsedArgs> local = Parse({});
  ASSERT_TRUE(local.ok()) << local.status();
  EXPECT_EQ(std::get<daemon::Config>(*local).processing_backend,
            daemon::ProcessingBackend::kLocal)
      << "local is the default";
  EXPECT_THAT(
      Parse({"--processing-backend", "pbs"}),
      testing::StatusIs(absl::StatusCode::kInvalidArgument,
                        HasSubstr("--processing-backend: 'pbs' is not one of "
                                  "local, slurm")));
  EXPECT_THAT(Parse({"--hardware", "usb"}),
              testing::StatusIs(
                  absl::StatusCode::kInvalidArgument,
                  HasSubstr("--hardware: 'usb' is not one of real, sim")));
}

// What a processing job may take of memory: Slurm's sizes, for both
// backends, from flag or config, checked when the configuration is read.
TEST(DeployTest, MemorySizesAreSlurmsAndCheckedAtStart) {
  const std::vector<std::pair<std::string, int64_t>> good = {
      {"8G", int64_t{8} << 30},
      {"512m", int64_t{512} << 20},
      {"4096", int64_t{4096} << 20},  // no unit is Slurm's megabytes
      {"1T", int64_t{1} << 40},
      {"64K", int64_t{64} << 10},
      {"0", 0}};  // no limit (Slurm: the node's whole memory)
  for (const auto& [text, bytes] : good) {
    absl::StatusOr<int64_t> parsed = daemon::ParseMemorySize(text);
    ASSERT_TRUE(parsed.ok()) << text << ": " << parsed.status();
    EXPECT_EQ(*parsed, bytes) << text;
  }
  for (const char* bad :
       {"", "G", "8X", "-1G", "1.5G", "8 G", "2000T", "99999999999999999999"}) {
    EXPECT_THAT(daemon::ParseMemorySize(bad),
                testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                  HasSubstr("is not a memory size")))
        << bad;
  }

  testing::TempDir dir;
  const std::string path = (dir / "memory.toml").string();
  std::ofstream(path) << "[processing]\nmemory = \"12G\"\n";
  ASSERT_OK_AND_ASSIGN(const daemon::ParsedArgs from_file,
                       Parse({"--config", path}));
  EXPECT_EQ(std::get<daemon::Config>(from_file).processing_memory, "12G");
  ASSERT_OK_AND_ASSIGN(const daemon::ParsedArgs from_flag,
                       Parse({"--processing-memory", "6G"}));
  EXPECT_EQ(std::get<daemon::Config>(from_flag).processing_memory, "6G");
  EXPECT_THAT(Parse({"--processing-memory", "lots"}),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("--processing-memory: \"lots\" is "
                                          "not a memory size")));
  EXPECT_THAT(Parse({"--slurm-memory", "16 G"}),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("not a memory size")));
}

TEST(DeployTest, BadTlsAndAuthConfigIsRefusedByName) {
  testing::TempDir dir;
  auto refused = [&](const std::string& toml) {
    const std::string path = (dir / "bad.toml").string();
    std::ofstream(path) << toml;
    absl::StatusOr<daemon::ParsedArgs> parsed = Parse({"--config", path});
    EXPECT_FALSE(parsed.ok()) << toml;
    return parsed.ok() ? std::string() : std::string(parsed.status().message());
  };
  EXPECT_THAT(refused("[tls]\ncertfile = \"x\"\n"), HasSubstr("certfile"));
  EXPECT_THAT(refused("[auth]\nroles = \"x\"\n"), HasSubstr("roles"));
  EXPECT_THAT(refused("[auth.users]\nalice = \"boss\"\n"),
              HasSubstr("[auth.users] alice = \"boss\""));
  EXPECT_THAT(refused("[auth.users]\n\"a b\" = \"viewer\"\n"),
              HasSubstr("contains ' '"));
  EXPECT_THAT(refused("[auth]\nlocal-role = \"root\"\n"),
              HasSubstr("local-role"));
  EXPECT_THAT(refused("[tls]\ncert = \"/c.pem\"\nkey = \"/k.pem\"\n"),
              HasSubstr("--tls-client-ca ([tls] client-ca) is missing"));
}

TEST(DeployTest, MetricsAreOffByDefaultAndLoopbackOnly) {
  absl::StatusOr<daemon::ParsedArgs> none = Parse({});
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_EQ(std::get<daemon::Config>(*none).metrics_listen, "");
  testing::TempDir dir;
  const std::string path = (dir / "metrics.toml").string();
  std::ofstream(path) << "metrics-listen = \"127.0.0.1:9464\"\n";
  absl::StatusOr<daemon::ParsedArgs> keyed = Parse({"--config", path});
  ASSERT_TRUE(keyed.ok()) << keyed.status();
  EXPECT_EQ(std::get<daemon::Config>(*keyed).metrics_listen, "127.0.0.1:9464");
  for (const char* bad :
       {"0.0.0.0:9464", "127.0.0.1", "127.0.0.1:70000", "unix:/tmp/m.sock"}) {
    absl::StatusOr<daemon::ParsedArgs> parsed =
        Parse({"--metrics-listen", bad});
    EXPECT_THAT(parsed.status(),
                testing::StatusIs(
                    absl::StatusCode::kInvalidArgument,
                    HasSubstr(absl::StrCat("--metrics-listen \"", bad, "\""))));
  }
}

TEST(DeployTest, ANonLoopbackAddressNeedsTls) {
  absl::StatusOr<daemon::ParsedArgs> plain =
      Parse({"--listen", "0.0.0.0:50051"});
  ASSERT_FALSE(plain.ok());
  EXPECT_THAT(std::string(plain.status().message()),
              HasSubstr("is not a loopback address; remote access needs TLS"));
  absl::StatusOr<daemon::ParsedArgs> tls =
      Parse({"--listen", "0.0.0.0:50051", "--tls-cert", "/c.pem", "--tls-key",
             "/k.pem", "--tls-client-ca", "/ca.pem"});
  EXPECT_TRUE(tls.ok()) << tls.status();
  EXPECT_TRUE(
      Parse({"--listen", "unix:/tmp/x.sock", "--listen", "127.0.0.1:0"}).ok());
  EXPECT_FALSE(Parse({"--listen", ":50051"}).ok());
}

TEST(DeployTest, MinBatteryPercentIsAPercentageFromFlagOrConfig) {
  absl::StatusOr<daemon::ParsedArgs> ok =
      Parse({"--min-battery-percent", "20"});
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(std::get<daemon::Config>(*ok).min_battery_percent, 20);
  for (const char* bad : {"-1", "101", "half"}) {
    absl::StatusOr<daemon::ParsedArgs> refused =
        Parse({"--min-battery-percent", bad});
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_THAT(std::string(refused.status().message()),
                HasSubstr("--min-battery-percent"))
        << bad;
  }
  testing::TempDir dir;
  const std::string path = (dir / "battery.toml").string();
  std::ofstream(path) << "min-battery-percent = 150\n";
  absl::StatusOr<daemon::ParsedArgs> from_file = Parse({"--config", path});
  ASSERT_FALSE(from_file.ok());
  EXPECT_THAT(std::string(from_file.status().message()),
              HasSubstr("min-battery-percent"));
}

TEST(DeployTest, CameraReconnectBackoffFromFlagOrConfig) {
  absl::StatusOr<daemon::ParsedArgs> defaults = Parse({});
  ASSERT_TRUE(defaults.ok()) << defaults.status();
  EXPECT_EQ(std::get<daemon::Config>(*defaults).camera_reconnect_first_s, 0.5);
  EXPECT_EQ(std::get<daemon::Config>(*defaults).camera_reconnect_max_s, 30);
  absl::StatusOr<daemon::ParsedArgs> ok = Parse(
      {"--camera-reconnect-first-s", "0.2", "--camera-reconnect-max-s", "5"});
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(std::get<daemon::Config>(*ok).camera_reconnect_first_s, 0.2);
  EXPECT_EQ(std::get<daemon::Config>(*ok).camera_reconnect_max_s, 5);
  for (const char* option :
       {"--camera-reconnect-first-s", "--camera-reconnect-max-s"}) {
    for (const char* bad : {"0", "-1", "7200", "soon"}) {
      absl::StatusOr<daemon::ParsedArgs> refused = Parse({option, bad});
      ASSERT_FALSE(refused.ok()) << option << " " << bad;
      EXPECT_THAT(std::string(refused.status().message()), HasSubstr(option))
          << bad;
    }
  }
  EXPECT_THAT(Parse({"--camera-reconnect-first-s", "10",
                     "--camera-reconnect-max-s", "2"})
                  .status(),
              testing::StatusIs(
                  absl::StatusCode::kInvalidArgument,
                  HasSubstr("--camera-reconnect-first-s 10 is longer than "
                            "--camera-reconnect-max-s 2")));
  testing::TempDir dir;
  const std::string path = (dir / "reconnect.toml").string();
  std::ofstream(path) << "camera-reconnect-max-s = 0\n";
  absl::StatusOr<daemon::ParsedArgs> from_file = Parse({"--config", path});
  ASSERT_FALSE(from_file.ok());
  EXPECT_THAT(std::string(from_file.status().message()),
              HasSubstr("camera-reconnect-max-s"));
}

// A network camera: "ptpip:ADDRESS[:PORT]" is checked, one port serves
// both of libgphoto2's connections, and the model defaults to its generic
// "PTP/IP Camera". The simulated camera can be served the same way.
TEST(DeployTest, NetworkCameraPortsAndTheSimulatedPtpIpCamera) {
  absl::StatusOr<daemon::ParsedArgs> ptpip =
      Parse({"--hardware", "real", "--camera-port", "ptpip:192.168.1.20:4000"});
  ASSERT_TRUE(ptpip.ok()) << ptpip.status();
  EXPECT_EQ(std::get<daemon::Config>(*ptpip).camera_port,
            "ptpip:192.168.1.20:4000:4000");
  EXPECT_EQ(std::get<daemon::Config>(*ptpip).camera_model, "PTP/IP Camera");
  absl::StatusOr<daemon::ParsedArgs> named =
      Parse({"--camera-port", "ptpip:10.0.0.7", "--camera-model",
             "Nikon DSLR (WLAN)"});
  ASSERT_TRUE(named.ok()) << named.status();
  EXPECT_EQ(std::get<daemon::Config>(*named).camera_port, "ptpip:10.0.0.7");
  EXPECT_EQ(std::get<daemon::Config>(*named).camera_model, "Nikon DSLR (WLAN)");
  EXPECT_THAT(Parse({"--camera-port", "ptpip:camera.lab"}).status(),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("an IPv4 address (libgphoto2 looks "
                                          "up no host names)")));
  EXPECT_THAT(Parse({"--camera-port", "ptpip:10.0.0.7:99999"}).status(),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("\"99999\" is not a TCP port")));

  absl::StatusOr<daemon::ParsedArgs> sim =
      Parse({"--sim-camera", "ptpip", "--sim-camera-format", "tiff16"});
  ASSERT_TRUE(sim.ok()) << sim.status();
  EXPECT_EQ(std::get<daemon::Config>(*sim).sim_camera, "ptpip");
  EXPECT_EQ(std::get<daemon::Config>(*sim).sim_camera_format, "tiff16");
  EXPECT_FALSE(Parse({"--sim-camera", "usb"}).ok());
  EXPECT_FALSE(Parse({"--sim-camera-format", "gif"}).ok());
}

// The console's folder: unset by default (the daemon then looks beside its
// executable), from the flag or the config's web-root, the flag winning.
TEST(DeployTest, WebRootFromFlagOrConfig) {
  ASSERT_OK_AND_ASSIGN(daemon::ParsedArgs defaults, Parse({}));
  EXPECT_EQ(std::get<daemon::Config>(defaults).web_root, "");
  ASSERT_OK_AND_ASSIGN(daemon::ParsedArgs flag,
                       Parse({"--web-root", "/opt/hdrstereo/web"}));
  EXPECT_EQ(std::get<daemon::Config>(flag).web_root, "/opt/hdrstereo/web");
  ASSERT_OK_AND_ASSIGN(
      daemon::ParsedArgs text,
      daemon::ParseConfigText("web-root = \"/srv/console\"\n"));
  EXPECT_EQ(std::get<daemon::Config>(text).web_root, "/srv/console");
  testing::TempDir dir;
  const std::string path = (dir / "web.toml").string();
  std::ofstream(path) << "web-root = \"/srv/console\"\n";
  ASSERT_OK_AND_ASSIGN(daemon::ParsedArgs both,
                       Parse({"--config", path, "--web-root", "/opt/web"}));
  EXPECT_EQ(std::get<daemon::Config>(both).web_root, "/opt/web");
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

// ParseConfigText reads a config from memory as --config reads the file.
TEST(DeployTest, ConfigTextParsesAsTheConfigFile) {
  const std::string shipped = Read(kSource + "/deploy/config/hdrstereod.toml");
  ASSERT_OK_AND_ASSIGN(daemon::ParsedArgs text,
                       daemon::ParseConfigText(shipped));
  ASSERT_OK_AND_ASSIGN(
      daemon::ParsedArgs file,
      Parse({"--config", kSource + "/deploy/config/hdrstereod.toml"}));
  const auto& from_text = std::get<daemon::Config>(text);
  const auto& from_file = std::get<daemon::Config>(file);
  EXPECT_EQ(from_text.data_root, from_file.data_root);
  EXPECT_EQ(from_text.listen, from_file.listen);
  EXPECT_EQ(from_text.stage_port, from_file.stage_port);
  EXPECT_EQ(from_text.log_file, from_file.log_file);
  EXPECT_EQ(from_text.hardware, hardware::HardwareMode::kReal);

  ASSERT_OK_AND_ASSIGN(daemon::ParsedArgs users,
                       daemon::ParseConfigText("[auth.users]\nalice = "
                                               "\"viewer\"\n[slurm]\ncpus-"
                                               "per-task = 8\n"));
  EXPECT_THAT(std::get<daemon::Config>(users).users,
              ::testing::ElementsAre(::testing::Pair("alice", "viewer")));
  EXPECT_EQ(std::get<daemon::Config>(users).slurm.cpus_per_task, 8);
  EXPECT_THAT(daemon::ParseConfigText("stage-prot = \"/dev/ttyUSB1\"\n"),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("stage-prot")));
}

// The limits on a config, from memory and from a file; a config names no
// other config; what CLI11 or the file system throw becomes a status.
TEST(DeployTest, ConfigsBeyondTheLimitsAreRefusedByName) {
  testing::TempDir dir;
  auto from_file = [&](const std::string& toml) {
    const std::string path = (dir / "hostile.toml").string();
    std::ofstream(path) << toml;
    return Parse({"--config", path});
  };
  const std::string huge(daemon::kMaxConfigBytes + 1, '#');
  EXPECT_THAT(daemon::ParseConfigText(huge),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("the config is 1048577 bytes; the "
                                          "most is 1048576")));
  EXPECT_THAT(from_file(huge + huge),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("the config is more than 1048576 "
                                          "bytes")));
  ASSERT_OK_AND_ASSIGN(daemon::ParsedArgs comments, from_file(huge.substr(1)));
  EXPECT_EQ(std::get<daemon::Config>(comments).data_root, "data");

  // Four levels pass the depth check (and are refused as unknown).
  EXPECT_THAT(daemon::ParseConfigText("[a.b.c.d]\nx = 1\n"),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("INI was not able to parse a.")));
  std::string deep = "[a";
  for (int i = 0; i < 20000; ++i) deep += ".a";
  deep += "]\nx = 1\n";
  for (const absl::StatusOr<daemon::ParsedArgs>& parsed :
       {daemon::ParseConfigText("\n[a.b.c.d.e]\n"), from_file(deep)}) {
    EXPECT_THAT(parsed, testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                          HasSubstr("deep; the most is 4")));
    EXPECT_LT(parsed.status().message().size(), 200u);
  }
  EXPECT_THAT(daemon::ParseConfigText("\n[a.b.c.d.e]\n"),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("config line 2: section "
                                          "\"[a.b.c.d.e]\" nests 5 deep")));

  const std::string value(daemon::kMaxConfigItemBytes + 1, 'v');
  absl::StatusOr<daemon::ParsedArgs> long_value =
      daemon::ParseConfigText("[slurm]\npartition = \"" + value + "\"\n");
  EXPECT_THAT(long_value,
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("config: slurm.partition = \"vvv")));
  EXPECT_THAT(long_value,
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("\"... (4097 bytes): the value is "
                                          "4097 bytes long; the most is "
                                          "4096")));
  EXPECT_LT(long_value.status().message().size(), 200u);
  ASSERT_OK_AND_ASSIGN(daemon::ParsedArgs at_limit,
                       daemon::ParseConfigText("[slurm]\npartition = \"" +
                                               value.substr(1) + "\"\n"));
  EXPECT_EQ(std::get<daemon::Config>(at_limit).slurm.partition.size(),
            daemon::kMaxConfigItemBytes);
  EXPECT_THAT(daemon::ParseConfigText(value + " = 1\n"),
              testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                HasSubstr("(4097 bytes) is 4097 bytes long; "
                                          "the most is 4096")));

  for (const absl::StatusOr<daemon::ParsedArgs>& parsed :
       {daemon::ParseConfigText("config = \"/dev/zero\"\n"),
        from_file("config = \"/dev/zero\"\n")}) {
    EXPECT_THAT(parsed,
                testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                  HasSubstr("config: This option is not "
                                            "allowed in a configuration "
                                            "file")));
  }
  // std::filesystem::absolute("") throws; the parser answers.
  EXPECT_THAT(daemon::ParseConfigText("data-root = \"\"\n[slurm]\n"
                                      "data-root = \"/cluster\"\n"),
              testing::StatusIs(
                  absl::StatusCode::kInvalidArgument,
                  HasSubstr("--data-root \"\": cannot make it absolute")));
  EXPECT_THAT(daemon::ParseConfigText(std::string("\0\xff[[[\n=\n\x01", 9)),
              testing::StatusIs(absl::StatusCode::kInvalidArgument));
  absl::StatusOr<daemon::ParsedArgs> role = daemon::ParseConfigText(
      "[auth.users]\nalice = \"" + std::string(3000, 'r') + "\"\n");
  EXPECT_THAT(role, testing::StatusIs(absl::StatusCode::kInvalidArgument,
                                      HasSubstr("(3000 bytes): the role must "
                                                "be")));
  EXPECT_LT(role.status().message().size(), 300u);
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
    // Some options sit in their sections: [tls] cert for --tls-cert (and
    // likewise [slurm], [processing]), [auth] local-role, [auth.users] for
    // --auth-user.
    const std::string section = name.substr(0, name.find('-'));
    if (section == "tls" || section == "slurm" || section == "processing") {
      ASSERT_NE(toml.find("[" + section + "]"), std::string::npos) << name;
      EXPECT_THAT(
          toml.substr(toml.find("[" + section + "]") + 1),
          HasSubstr(absl::StrCat(name.substr(section.size() + 1), " = ")))
          << name;
    } else if (name == "auth-user") {
      EXPECT_THAT(toml, HasSubstr("[auth.users]"));
    } else if (name == "local-role") {
      EXPECT_THAT(toml.substr(toml.find("[auth]") + 1),
                  HasSubstr("local-role = "));
    } else {
      EXPECT_THAT(toml, HasSubstr(absl::StrCat(name, " = "))) << name;
    }
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
