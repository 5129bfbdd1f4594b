// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/config.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <exception>
#include <functional>
#include <map>
#include <sstream>
#include <system_error>
#include <vector>

#include "absl/algorithm/container.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "daemon/rpc/roles.h"
#include "hardware/gphoto2/settings.h"
#include "hdrstereo_version.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::daemon {
namespace {

// An option whose words name an enum's values. CLI11's CheckedTransformer
// would do, but its error lists the enum's integers; this one names the words.
template <typename Enum>
CLI::Validator OneOf(const std::map<std::string, Enum>& words) {
  std::vector<std::string> names;
  for (const auto& [name, value] : words) names.push_back(name);
  const std::string list = absl::StrJoin(names, ", ");
  return CLI::Validator(
      [words, list](std::string& input) -> std::string {
        const auto it = words.find(input);
        if (it == words.end()) {
          return absl::StrCat("'", input, "' is not one of ", list);
        }
        input = std::to_string(static_cast<int>(it->second));
        return "";
      },
      "{" + list + "}");
}

absl::Status CheckConfigSize(size_t bytes) {
  if (bytes > kMaxConfigBytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the config is ", bytes, " bytes; the most is ", kMaxConfigBytes));
  }
  return absl::OkStatus();
}

// The config text CLI11's reader is given, within kMaxConfigBytes and
// kMaxConfigSectionDepth: for every level a section opens and closes, the
// reader copies the section's parents, so a deeply nested header costs the
// square of its depth. Throws CLI::ConfigError, as the reader does.
std::string ReadBoundedConfig(std::istream& input) {
  std::string text;
  char buffer[4096];
  while (input.read(buffer, sizeof buffer) || input.gcount() > 0) {
    text.append(buffer, static_cast<size_t>(input.gcount()));
    if (text.size() > kMaxConfigBytes) {
      throw CLI::ConfigError(
          absl::StrCat("the config is more than ", kMaxConfigBytes, " bytes"));
    }
  }
  int line_no = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_no;
    line = absl::StripAsciiWhitespace(line);
    // A section header, as CLI11 tells one.
    if (line.size() < 3 || line.front() != '[' || line.back() != ']') continue;
    const int64_t depth = std::count(line.begin(), line.end(), '.') + 1;
    if (depth > kMaxConfigSectionDepth) {
      throw CLI::ConfigError(absl::StrCat(
          "config line ", line_no, ": section ", QuoteInput(line), " nests ",
          depth, " deep; the most is ", kMaxConfigSectionDepth));
    }
  }
  return text;
}

// Keys and values within kMaxConfigItemBytes (CLI11's messages repeat them).
void CheckItemSizes(const CLI::ConfigItem& item) {
  for (const std::string& key : item.parents) {
    if (key.size() > kMaxConfigItemBytes) {
      throw CLI::ConfigError(absl::StrCat(
          "config: the section name ", QuoteInput(key), " is ", key.size(),
          " bytes long; the most is ", kMaxConfigItemBytes));
    }
  }
  if (item.name.size() > kMaxConfigItemBytes) {
    throw CLI::ConfigError(absl::StrCat(
        "config: the key ", QuoteInput(item.name), " is ", item.name.size(),
        " bytes long; the most is ", kMaxConfigItemBytes));
  }
  for (const std::string& value : item.inputs) {
    if (value.size() > kMaxConfigItemBytes) {
      throw CLI::ConfigError(
          absl::StrCat("config: ", item.fullname(), " = ", QuoteInput(value),
                       ": the value is ", value.size(),
                       " bytes long; the most is ", kMaxConfigItemBytes));
    }
  }
}

// CLI11's TOML reader maps sections to subcommands; hdrstereod has none, so
// the [tls], [processing], [slurm] and [auth] sections are turned into the
// options they stand for before CLI11 sees them: [tls] cert -> tls-cert
// (likewise processing-... and slurm-...), [auth] local-role -> local-role,
// [auth.users] NAME = ROLE -> auth-user = "NAME=ROLE". Any other section
// stays as it is and is refused by name.
class SectionedToml : public CLI::ConfigTOML {
 public:
  std::vector<CLI::ConfigItem> from_config(std::istream& input) const override {
    std::istringstream bounded(ReadBoundedConfig(input));
    std::vector<CLI::ConfigItem> out;
    CLI::ConfigItem users;  // all of [auth.users] as one auth-user item
    users.name = "auth-user";
    for (CLI::ConfigItem& item : CLI::ConfigTOML::from_config(bounded)) {
      CheckItemSizes(item);
      const std::vector<std::string>& parents = item.parents;
      const bool prefixed =
          parents.size() == 1 &&
          (parents[0] == "tls" || parents[0] == "processing" ||
           parents[0] == "slurm");
      const bool ours = prefixed || (!parents.empty() && parents[0] == "auth");
      if (!ours) {
        out.push_back(std::move(item));
        continue;
      }
      if (item.name == "++" || item.name == "--") continue;  // section marks
      if (parents == std::vector<std::string>{"auth", "users"}) {
        users.inputs.push_back(absl::StrCat(
            item.name, "=", item.inputs.empty() ? "" : item.inputs[0]));
        continue;
      }
      if (prefixed) {
        item.name = absl::StrCat(parents[0], "-", item.name);
      } else if (parents != std::vector<std::string>{"auth"}) {
        out.push_back(std::move(item));  // e.g. [auth.other]: refused
        continue;
      }
      item.parents.clear();
      out.push_back(std::move(item));
    }
    // (An option takes its values from one config item.)
    if (!users.inputs.empty()) out.push_back(std::move(users));
    return out;
  }
};

absl::Status ParseUsers(const std::vector<std::string>& entries,
                        std::map<std::string, std::string>& users) {
  for (const std::string& entry : entries) {
    const size_t equals = entry.find('=');
    const std::string name = entry.substr(0, equals);
    const std::string role =
        equals == std::string::npos ? "" : entry.substr(equals + 1);
    RETURN_IF_ERROR(rpc::ValidatePrincipalName(name, "[auth.users]"));
    absl::StatusOr<rpc::Role> parsed = rpc::ParseRole(role);
    if (!parsed.ok() || *parsed == rpc::Role::kNone) {
      return absl::InvalidArgumentError(absl::StrCat(
          "[auth.users] ", name, " = ", QuoteInput(role),
          ": the role must be \"viewer\", \"operator\" or \"admin\""));
    }
    if (!users.emplace(name, role).second) {
      return absl::InvalidArgumentError(
          absl::StrCat("[auth.users] names ", name, " twice"));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateTls(const TlsConfig& tls) {
  const bool any =
      !tls.cert.empty() || !tls.key.empty() || !tls.client_ca.empty();
  if (!any) {
    if (!tls.crl_dir.empty()) {
      return absl::InvalidArgumentError(
          "--tls-crl-dir needs --tls-cert, --tls-key and --tls-client-ca");
    }
    return absl::OkStatus();
  }
  for (const auto& [path, name] :
       {std::pair{&tls.cert, "--tls-cert ([tls] cert)"},
        std::pair{&tls.key, "--tls-key ([tls] key)"},
        std::pair{&tls.client_ca, "--tls-client-ca ([tls] client-ca)"}}) {
    if (path->empty()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "TLS needs --tls-cert, --tls-key and --tls-client-ca together; ",
          name, " is missing"));
    }
  }
  return absl::OkStatus();
}

}  // namespace

const char* ProcessingBackendName(ProcessingBackend backend) {
  return backend == ProcessingBackend::kSlurm ? "slurm" : "local";
}

absl::StatusOr<int64_t> ParseMemorySize(absl::string_view text) {
  constexpr int64_t kMaxBytes = int64_t{1} << 50;
  const auto invalid = [&] {
    return absl::InvalidArgumentError(absl::StrCat(
        QuoteInput(text),
        " is not a memory size: a whole number with K, M, G or T (M when "
        "none), e.g. 8G, up to 1 PiB; 0 for no limit"));
  };
  int shift = 20;  // Slurm's unit when there is none
  absl::string_view digits = text;
  constexpr absl::string_view kUnits = "KMGT";
  if (const size_t unit = digits.empty()
                              ? absl::string_view::npos
                              : kUnits.find(absl::ascii_toupper(
                                    static_cast<unsigned char>(digits.back())));
      unit != absl::string_view::npos) {
    shift = 10 * static_cast<int>(unit + 1);
    digits.remove_suffix(1);
  }
  int64_t value = 0;
  if (digits.empty() || digits.size() > 16 ||
      !std::all_of(digits.begin(), digits.end(),
                   [](char c) { return c >= '0' && c <= '9'; }) ||
      !absl::SimpleAtoi(digits, &value) || value < 0 ||
      value > (kMaxBytes >> shift)) {
    return invalid();
  }
  return value << shift;
}

bool IsLocalAddress(const std::string& address) {
  if (absl::StartsWith(address, "unix:")) return true;
  const std::string host = address.substr(0, address.rfind(':'));
  return host == "localhost" || host == "[::1]" ||
         absl::StartsWith(host, "127.");
}

absl::Status ValidateListenAddress(const std::string& address,
                                   const TlsConfig& tls) {
  if (absl::StartsWith(address, "unix:")) {
    if (address.size() > 5) return absl::OkStatus();
    return absl::InvalidArgumentError("--listen unix: needs a socket path");
  }
  size_t colon = address.rfind(':');
  if (colon == std::string::npos) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--listen ", QuoteInput(address), " must be HOST:PORT or unix:PATH"));
  }
  std::string host = address.substr(0, colon);
  int port = 0;
  if (!absl::SimpleAtoi(address.substr(colon + 1), &port) || port < 0 ||
      port > 65535) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--listen ", QuoteInput(address), " has no valid port (0-65535)"));
  }
  if (host.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--listen ", QuoteInput(address),
                     " has no host; use e.g. 0.0.0.0:", port));
  }
  if (IsLocalAddress(address) || tls.enabled()) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(
      "--listen ", QuoteInput(address),
      " is not a loopback address; remote access needs TLS: give "
      "--tls-cert, --tls-key and --tls-client-ca (or [tls] in the config; "
      "deploy/make-certs.sh makes them), or listen on 127.0.0.1 or a unix "
      "socket"));
}

absl::Status ValidateHttpAddress(const std::string& address,
                                 const TlsConfig& tls) {
  const size_t colon = address.rfind(':');
  int port = -1;
  if (absl::StartsWith(address, "unix:") || colon == std::string::npos ||
      colon == 0 || !absl::SimpleAtoi(address.substr(colon + 1), &port) ||
      port < 0 || port > 65535) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--http-listen ", QuoteInput(address), " must be HOST:PORT"));
  }
  if (IsLocalAddress(address) || tls.enabled()) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(
      "--http-listen ", QuoteInput(address),
      " is not a loopback address: HTTP off loopback needs TLS (--tls-cert "
      "and --tls-key; deploy/make-certs.sh makes them), or listen on "
      "127.0.0.1"));
}

absl::Status ValidateMetricsAddress(const std::string& address) {
  if (address.empty()) return absl::OkStatus();
  size_t colon = address.rfind(':');
  int port = 0;
  if (colon == std::string::npos ||
      !absl::SimpleAtoi(address.substr(colon + 1), &port) || port < 0 ||
      port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("--metrics-listen ", QuoteInput(address),
                     " must be HOST:PORT (port 0-65535)"));
  }
  if (absl::StartsWith(address, "unix:") || !IsLocalAddress(address)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--metrics-listen ", QuoteInput(address),
        " is not a loopback address; the metrics endpoint has no TLS or "
        "authentication: listen on 127.0.0.1 and let a proxy expose it"));
  }
  return absl::OkStatus();
}

namespace {

// The options parsed by `parse` (the command line, or a config text), then
// checked together.
absl::StatusOr<ParsedArgs> Parse(const std::function<void(CLI::App&)>& parse) {
  Config config;
  std::vector<std::string> users;
  CLI::App app{"hdrstereod: HDR stereo acquisition daemon", "hdrstereod"};
  app.set_version_flag("--version", HDRSTEREO_VERSION);
  app.set_config("--config", "", "Read options from a TOML file")
      ->check(CLI::ExistingFile)
      ->configurable(false);
  app.config_formatter(std::make_shared<SectionedToml>());
  app.allow_config_extras(false);
  app.add_option("--listen", config.listen,
                 "Address(es) to serve gRPC on: HOST:PORT or unix:PATH; "
                 "loopback and unix without TLS (as principal \"local\"), "
                 "any other address only with TLS")
      ->capture_default_str();
  app.add_option("--data-root", config.data_root,
                 "Folder holding hdrstereo.db and the session folders")
      ->capture_default_str();
  app.add_option("--hardware", config.hardware, "Devices to drive")
      ->transform(OneOf(std::map<std::string, hardware::HardwareMode>{
          {"sim", hardware::HardwareMode::kSim},
          {"real", hardware::HardwareMode::kReal}}))
      ->default_str(hardware::HardwareModeName(config.hardware));
  app.add_option("--log-file", config.log_file,
                 "Rotating log file [default: DATA_ROOT/logs/hdrstereod.log]");
  app.add_option("--log-level", config.log_level, "Console and file log level")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
  app.add_option("--ready-file", config.ready_file,
                 "Write the bound address here once serving");
  app.add_option("--processing-threads", config.processing_threads,
                 "Processing jobs run in parallel")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  const CLI::Validator memory_size(
      [](std::string& input) -> std::string {
        absl::StatusOr<int64_t> bytes = ParseMemorySize(input);
        return bytes.ok() ? "" : std::string(bytes.status().message());
      },
      "SIZE");
  app.add_option("--processing-memory", config.processing_memory,
                 "Memory one processing job may use with backend local, "
                 "e.g. 16G, 0 = no limit; a job that would need more is "
                 "refused [default: this machine's memory shared by the "
                 "processing threads]")
      ->check(memory_size);
  app.add_option("--processing-backend", config.processing_backend,
                 "Where processing jobs run: in this process, or as Slurm "
                 "batch jobs ([slurm] options)")
      ->transform(OneOf(std::map<std::string, ProcessingBackend>{
          {"local", ProcessingBackend::kLocal},
          {"slurm", ProcessingBackend::kSlurm}}))
      ->default_str(ProcessingBackendName(config.processing_backend));
  app.add_option("--max-cluster-jobs", config.max_cluster_jobs,
                 "Slurm backend: processing jobs on the cluster at once")
      ->check(CLI::Range(1, 10000))
      ->capture_default_str();
  slurm::SlurmOptions& slurm = config.slurm;
  app.add_option("--slurm-partition", slurm.partition,
                 "Slurm partition [default: the cluster's]");
  app.add_option("--slurm-account", slurm.account, "Slurm account to charge");
  app.add_option("--slurm-qos", slurm.qos, "Slurm quality of service");
  app.add_option("--slurm-cpus-per-task", slurm.cpus_per_task,
                 "CPUs per batch job, also the pipeline's threads there")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  app.add_option("--slurm-memory", slurm.memory,
                 "Memory per batch job, e.g. 8G (0 = the node's); a job "
                 "that would need more is refused [default: the cluster's, "
                 "unchecked]")
      ->check(memory_size);
  app.add_option("--slurm-time-limit", slurm.time_limit,
                 "Time limit per batch job, e.g. 02:00:00");
  app.add_option("--slurm-extra-arg", slurm.extra_sbatch_args,
                 "Another sbatch argument, as sbatch takes it "
                 "(repeatable; [slurm] extra-arg = [...])")
      ->allow_extra_args(false);
  app.add_option("--slurm-proc-path", slurm.proc_path,
                 "hdrstereo-proc as the compute nodes see it")
      ->capture_default_str();
  app.add_option("--slurm-data-root", slurm.cluster_data_root,
                 "The data root as the compute nodes mount it [default: the "
                 "same path as here]");
  app.add_option("--slurm-conf", slurm.conf,
                 "slurm.conf for sbatch, squeue, scontrol and scancel "
                 "[default: theirs]");
  app.add_option("--slurm-poll-s", slurm.poll_s,
                 "How often a batch job's state is asked for")
      ->check(CLI::Range(0.05, 600.0))
      ->capture_default_str();
  app.add_option("--disk-margin-mb", config.disk_margin_mb,
                 "Free space a capture must leave on the data root")
      ->check(CLI::Range(int64_t{0}, int64_t{1} << 30))
      ->capture_default_str();
  app.add_option("--frame-bytes-guess-mb", config.frame_bytes_guess_mb,
                 "Frame size assumed before a capture of its kind is on disk")
      ->check(CLI::Range(int64_t{0}, int64_t{1} << 20))
      ->capture_default_str();
  app.add_option("--min-battery-percent", config.min_battery_percent,
                 "A capture suspends while the camera battery is below this")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  app.add_option("--metrics-listen", config.metrics_listen,
                 "Serve Prometheus metrics on this loopback HOST:PORT "
                 "(e.g. 127.0.0.1:9464) [default: off]");
  app.add_option("--http-listen", config.http_listen,
                 "Serve the API over HTTP (browsers, curl, MATLAB) on "
                 "HOST:PORT, may be given several times; loopback without "
                 "TLS, any other address only with TLS; every request needs "
                 "credentials [default: off]");
  app.add_option("--http-host", config.http_hosts,
                 "A host name the HTTP edge answers to (the Host header), "
                 "besides its listen addresses and localhost; may be given "
                 "several times");
  app.add_option("--http-session-idle-minutes",
                 config.http_session_idle_minutes,
                 "A browser session ends after this long without a request")
      ->check(CLI::Range(1.0, 24.0 * 60))
      ->capture_default_str();
  app.add_option("--http-session-lifetime-hours",
                 config.http_session_lifetime_hours,
                 "A browser session ends this long after sign-in")
      ->check(CLI::Range(0.1, 24.0 * 31))
      ->capture_default_str();
  app.add_option("--http-max-connections", config.http_max_connections,
                 "HTTP connections served at once; more are refused (503)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--http-max-body-kb", config.http_max_body_kb,
                 "The largest HTTP request body, in KiB")
      ->check(CLI::Range(int64_t{1}, int64_t{64} << 10))
      ->capture_default_str();
  app.add_option("--web-root", config.web_root,
                 "The operator's console the HTTP edge serves at /: the "
                 "folder of its built files, read at startup (it must "
                 "exist when given) [default: <folder of hdrstereod>/../"
                 "share/hdrstereo/web, where the build and deploy/install.sh "
                 "put it]");
  app.add_option("--webhook-max-attempts", config.webhook_max_attempts,
                 "Attempts at each webhook event before giving up")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  app.add_option("--webhook-first-retry-s", config.webhook_first_retry_s,
                 "Delay before a webhook's first retry (doubles per attempt)")
      ->check(CLI::Range(0.01, 3600.0))
      ->capture_default_str();
  app.add_option("--webhook-timeout-s", config.webhook_timeout_s,
                 "Time limit of one webhook request")
      ->check(CLI::Range(0.1, 300.0))
      ->capture_default_str();
  app.add_option("--resume-interrupted", config.resume_interrupted,
                 "Resume jobs a stop interrupted")
      ->capture_default_str();
  app.add_option("--scheduler-clock-rate", config.scheduler_clock_rate,
                 "Test only: scheduler clock speed relative to the wall clock")
      ->check(CLI::Range(1.0, 100000.0))
      ->capture_default_str();
  app.add_option("--home-position-mm", config.home_position_mm,
                 "Stage position of the left view")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--camera-model", config.camera_model,
                 "libgphoto2 camera model [default: first found]");
  app.add_option("--camera-port", config.camera_port,
                 "libgphoto2 port, e.g. usb:001,004, or a network camera "
                 "ptpip:ADDRESS[:PORT] (IPv4; default port 15740)");
  app.add_option("--camera-dump", config.camera_dump,
                 "With --hardware real: replay this `gphoto2 --summary "
                 "--list-all-config` dump as the camera (frames, stage and "
                 "projector simulated from --sim-scene)")
      ->check(CLI::ExistingFile);
  app.add_option("--camera-reconnect-first-s", config.camera_reconnect_first_s,
                 "Wait before looking for a camera that dropped or is not "
                 "there (doubles per failed attempt)")
      ->check(CLI::Range(0.01, 3600.0))
      ->capture_default_str();
  app.add_option("--camera-reconnect-max-s", config.camera_reconnect_max_s,
                 "Longest wait between two attempts at finding the camera")
      ->check(CLI::Range(0.01, 3600.0))
      ->capture_default_str();
  app.add_option("--stage-port", config.stage_port, "Zaber serial port")
      ->capture_default_str();
  app.add_option("--stage-device", config.stage_device, "Zaber device number")
      ->check(CLI::Range(1, 99))
      ->capture_default_str();
  app.add_option("--stage-axis", config.stage_axis, "Zaber axis number")
      ->check(CLI::Range(1, 9))
      ->capture_default_str();
  app.add_option("--stage-travel-mm", config.stage_travel_mm, "Stage travel")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--stage-microstep-um", config.stage_microstep_um,
                 "Distance of one microstep")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--projector-display", config.projector_display,
                 "X display of the projector [default: $DISPLAY]");
  app.add_option("--projector-x", config.projector_x, "Projector left edge");
  app.add_option("--projector-y", config.projector_y, "Projector top edge");
  app.add_option("--projector-width", config.projector_width,
                 "Projector width in pixels [default: screen]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--projector-height", config.projector_height,
                 "Projector height in pixels [default: screen]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--projector-settle-s", config.projector_settle_s,
                 "Wait after showing a pattern")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  app.add_option("--sim-scene", config.sim_scene,
                 "Simulated scene: bundled name or JSON file")
      ->capture_default_str();
  app.add_option("--sim-time-scale", config.sim_time_scale,
                 "Simulated hardware time: 0 = instant, 1 = real time")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  app.add_option("--sim-camera", config.sim_camera,
                 "How the simulated camera is driven: direct, or ptpip (a "
                 "PTP/IP camera on loopback, through libgphoto2 and the real "
                 "camera driver)")
      ->check(CLI::IsMember({"direct", "ptpip"}))
      ->capture_default_str();
  app.add_option("--sim-camera-format", config.sim_camera_format,
                 "The one format the simulated PTP/IP camera delivers: png8, "
                 "tiff16, jpeg or raw")
      ->check(CLI::IsMember({"png8", "tiff16", "jpeg", "raw"}))
      ->capture_default_str();
  app.add_option("--tls-cert", config.tls.cert,
                 "Server certificate chain (PEM) for non-local addresses");
  app.add_option("--tls-key", config.tls.key,
                 "Its private key (PEM; readable by hdrstereod only)");
  app.add_option("--tls-client-ca", config.tls.client_ca,
                 "CA certificate(s) that sign client certificates (PEM)");
  app.add_option("--tls-crl-dir", config.tls.crl_dir,
                 "Folder of that CA's revocation lists (<hash>.r0)");
  app.add_option("--local-role", config.local_role,
                 "Role of every caller on a loopback address or unix socket")
      ->check(CLI::IsMember({"viewer", "operator", "admin"}))
      ->capture_default_str();
  app.add_option("--auth-user", users,
                 "NAME=ROLE: the role of a certificate's or key's principal "
                 "(repeatable; [auth.users] in the config)");
  try {
    parse(app);
  } catch (const CLI::CallForVersion&) {
    return ParsedArgs(
        ExitWithText{absl::StrCat("hdrstereod ", HDRSTEREO_VERSION)});
  } catch (const CLI::Success&) {
    return ParsedArgs(ExitWithText{app.help()});
  } catch (const CLI::Error& e) {
    return absl::InvalidArgumentError(e.what());
  } catch (const std::exception& e) {
    // E.g. std::bad_alloc: no exception leaves the parser.
    return absl::InternalError(
        absl::StrCat("reading the options failed: ", e.what()));
  }
  RETURN_IF_ERROR(ValidateTls(config.tls));
  for (const std::string& address : config.listen) {
    RETURN_IF_ERROR(ValidateListenAddress(address, config.tls));
  }
  RETURN_IF_ERROR(ParseUsers(users, config.users));
  RETURN_IF_ERROR(ValidateMetricsAddress(config.metrics_listen));
  for (const std::string& address : config.http_listen) {
    RETURN_IF_ERROR(ValidateHttpAddress(address, config.tls));
  }
  for (const std::string& host : config.http_hosts) {
    if (host.empty() || host.size() > 253 || !absl::c_all_of(host, [](char c) {
          return absl::ascii_isalnum(c) || c == '-' || c == '.' || c == '_' ||
                 c == '[' || c == ']' || c == ':';
        })) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--http-host ", QuoteInput(host),
          " is not a host name (letters, digits, '-', '.', or an IP)"));
    }
  }
  if (config.camera_reconnect_first_s > config.camera_reconnect_max_s) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--camera-reconnect-first-s ", config.camera_reconnect_first_s,
        " is longer than --camera-reconnect-max-s ",
        config.camera_reconnect_max_s,
        ", the longest wait between two attempts at finding the camera"));
  }
  {
    absl::StatusOr<std::string> port =
        gphoto2::NormalizeCameraPort(config.camera_port);
    if (!port.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--camera-port: ", port.status().message()));
    }
    config.camera_port = *std::move(port);
    // Autodetection does not look on the network: a PTP/IP camera is
    // opened as libgphoto2's generic PTP/IP model unless one is named.
    if (gphoto2::IsNetworkPort(config.camera_port) &&
        config.camera_model.empty()) {
      config.camera_model = "PTP/IP Camera";
    }
  }
  if (!config.camera_dump.empty() &&
      config.hardware != hardware::HardwareMode::kReal) {
    return absl::InvalidArgumentError(
        "--camera-dump replays a real camera for the real camera driver: "
        "use it with --hardware real");
  }
  if (!config.slurm.cluster_data_root.empty()) {
    std::error_code error;
    const std::filesystem::path root =
        std::filesystem::absolute(config.data_root, error);
    if (error) {
      return absl::InvalidArgumentError(
          absl::StrCat("--data-root ", QuoteInput(config.data_root.string()),
                       ": cannot make it absolute for --slurm-data-root: ",
                       error.message()));
    }
    config.slurm.local_data_root = root.lexically_normal().string();
  }
  if (config.log_file.empty()) {
    config.log_file = config.data_root / "logs" / "hdrstereod.log";
  }
  return ParsedArgs(std::move(config));
}

}  // namespace

absl::StatusOr<ParsedArgs> ParseArgs(int argc, const char* const* argv) {
  return Parse([&](CLI::App& app) { app.parse(argc, argv); });
}

absl::StatusOr<ParsedArgs> ParseConfigText(absl::string_view toml_text) {
  RETURN_IF_ERROR(CheckConfigSize(toml_text.size()));
  return Parse([&](CLI::App& app) {
    std::istringstream input{std::string(toml_text)};
    app.parse_from_stream(input);
  });
}

}  // namespace hdrstereo::daemon
