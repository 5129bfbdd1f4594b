// SPDX-License-Identifier: GPL-3.0-or-later
//
// hdrstereod's configuration: command-line flags, optionally read from a
// TOML/INI config file (--config); flags given on the command line win. In
// the file, the TLS options may also sit in a [tls] section (cert = ... for
// --tls-cert), --local-role in [auth], and the users' roles in
// [auth.users] (alice = "viewer" for --auth-user alice=viewer).
#ifndef HDRSTEREO_DAEMON_CONFIG_H_
#define HDRSTEREO_DAEMON_CONFIG_H_

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/processing/slurm_cli.h"
#include "hardware/rig.h"

namespace hdrstereo::daemon {

// Remote access: the daemon's certificate, and the lab CA that signs the
// client certificates it accepts.
struct TlsConfig {
  std::filesystem::path cert;       // server certificate chain (PEM)
  std::filesystem::path key;        // its private key (PEM)
  std::filesystem::path client_ca;  // CA certificate(s) for clients (PEM)
  // Certificate revocation lists of that CA, as `openssl rehash` names
  // them (<hash>.r0); empty = no revocation checks.
  std::filesystem::path crl_dir;
  bool enabled() const { return !cert.empty(); }
};

// Where processing jobs run. kLocal: in this process, processing_threads at
// once; kSlurm: each is a Slurm batch job (daemon/jobs/slurm_processing.h),
// at most max_cluster_jobs at once. "local" / "slurm" in the configuration.
enum class ProcessingBackend { kLocal, kSlurm };
const char* ProcessingBackendName(ProcessingBackend backend);

// A memory size as Slurm's --mem takes it: a whole number with an optional
// K, M, G or T (powers of 1024; none = M), e.g. "8G", "512M", "4096"; 0 is
// no limit (Slurm: all of the node's memory). INVALID_ARGUMENT for
// anything else or more than 1 PiB.
absl::StatusOr<int64_t> ParseMemorySize(absl::string_view text);

struct Config {
  // Each address is HOST:PORT or unix:PATH. Loopback addresses and unix
  // sockets are served without TLS to the principal "local"; any other
  // address only with TLS.
  std::vector<std::string> listen = {"127.0.0.1:50051"};
  std::filesystem::path data_root = "data";
  hardware::HardwareMode hardware = hardware::HardwareMode::kSim;
  std::filesystem::path log_file;  // empty = <data_root>/logs/hdrstereod.log
  std::string log_level = "info";
  // Written (atomically) with the bound address once the server is serving;
  // lets scripts and tests use --listen 127.0.0.1:0.
  std::filesystem::path ready_file;
  int processing_threads = 2;
  // What one processing job may take of memory (ParseMemorySize; "0" = no
  // limit); empty = this machine's memory shared by processing_threads
  // jobs. A job that would need more is refused before it starts. With the
  // Slurm backend the budget is slurm.memory instead (unchecked when that
  // is empty or 0).
  std::string processing_memory;
  ProcessingBackend processing_backend = ProcessingBackend::kLocal;
  int max_cluster_jobs = 16;
  slurm::SlurmOptions slurm;
  // The disk guard (daemon/jobs/disk_guard.h): free space kept in reserve,
  // and the size of a frame before any capture of its kind is on disk.
  int64_t disk_margin_mb = 256;
  int64_t frame_bytes_guess_mb = 32;
  // A capture suspends while the camera reports less battery (0: never).
  int min_battery_percent = 0;
  bool resume_interrupted = true;
  // The Prometheus endpoint (daemon/metrics): loopback HOST:PORT, empty =
  // off. It has no TLS or authentication, hence loopback only.
  std::string metrics_listen;
  // The HTTP edge (daemon/http): HOST:PORT each, empty = off; loopback
  // addresses may be plain HTTP, any other needs the [tls] files. Every HTTP
  // request needs credentials, also on loopback.
  std::vector<std::string> http_listen;
  // Host names the HTTP edge answers to besides its listen addresses' own.
  std::vector<std::string> http_hosts;
  // Browser sessions end after this long without a request, and this long
  // after sign-in at the latest.
  double http_session_idle_minutes = 30;
  double http_session_lifetime_hours = 12;
  // HTTP connections served at once, and the largest request body.
  int http_max_connections = 256;
  int64_t http_max_body_kb = 4096;
  // The operator's console the HTTP edge serves at /: the folder of its
  // built files (daemon/http/console_files.h). Empty = <hdrstereod's
  // folder>/../share/hdrstereo/web (installed: /usr/local/share/...; the
  // build tree: build/share/...), served when it exists.
  std::filesystem::path web_root;
  // Webhook delivery (daemon/notify): attempts per event, the delay before
  // the first retry (doubling, at most 10 min), one request's time limit.
  int webhook_max_attempts = 8;
  double webhook_first_retry_s = 5;
  double webhook_timeout_s = 10;
  // Test only: the scheduler's clock runs this many times as fast as the
  // wall clock, so a test sees "* * * * *" come due within a second.
  double scheduler_clock_rate = 1;

  // The rig.
  double home_position_mm = 0;  // stage position of the left view
  // Real devices (--hardware real).
  std::string camera_model;  // empty = first camera found
  // e.g. "usb:001,004", or a network camera "ptpip:192.168.1.20[:PORT]"
  // (normalized by gphoto2::NormalizeCameraPort; the model then defaults
  // to libgphoto2's "PTP/IP Camera").
  std::string camera_port;
  // A `gphoto2 --summary --list-all-config` dump: the real camera driver
  // configures a replay of that camera, captures are rendered by the
  // simulator (scene sim_scene), and the stage and projector are the
  // simulated ones. Needs hardware "real"; empty = a real camera.
  std::filesystem::path camera_dump;
  // A camera that dropped, or that was not there at the start, is looked
  // for after this many seconds, then twice as long after each failed
  // attempt, at most camera_reconnect_max_s apart (any camera: also the
  // simulated and the replayed one).
  double camera_reconnect_first_s = 0.5;
  double camera_reconnect_max_s = 30;
  std::string stage_port = "/dev/ttyUSB0";
  int stage_device = 1;
  int stage_axis = 1;
  double stage_travel_mm = 150;
  double stage_microstep_um = 0.047625;
  std::string projector_display;  // empty = $DISPLAY
  int projector_x = 0;
  int projector_y = 0;
  int projector_width = 0;  // 0 = whole screen
  int projector_height = 0;
  double projector_settle_s = 0.1;
  // Simulated devices (--hardware sim).
  std::string sim_scene = "lab-lamp";  // bundled scene name or JSON file
  double sim_time_scale = 0;           // 0 = instant, 1 = real time
  // How the simulated camera is driven: "direct" (SimCamera, in process)
  // or "ptpip" (a simulated PTP/IP camera on a free loopback port, driven
  // by the real gphoto2 driver through libgphoto2). The PTP/IP camera
  // delivers one format, sim_camera_format ("png8", "tiff16", "jpeg",
  // "raw"); the direct one delivers what each capture asks for.
  std::string sim_camera = "direct";
  std::string sim_camera_format = "png8";

  // Security.
  TlsConfig tls;
  // The role of a caller on a loopback address or unix socket: anyone who
  // can reach it has this role.
  std::string local_role = "admin";
  // Roles of the principals of client certificates and API keys, by name:
  // "viewer", "operator" or "admin".
  std::map<std::string, std::string> users;
};

// The result of parsing: a config to run with, or a text (help, version) to
// print before exiting successfully.
struct ExitWithText {
  std::string text;
};
using ParsedArgs = std::variant<Config, ExitWithText>;

// Limits on a config file (it may be a copy from elsewhere): its size, how
// deep its sections nest ([auth.users] is 2), and the length of a key or a
// value (PATH_MAX). The shipped config is 8 KB.
inline constexpr size_t kMaxConfigBytes = size_t{1} << 20;
inline constexpr int64_t kMaxConfigSectionDepth = 4;
inline constexpr size_t kMaxConfigItemBytes = 4096;

// INVALID_ARGUMENT with a one-line message for unknown flags, unknown config
// keys, bad values, a config file beyond the limits above (a `config` key in
// it too: a config file names no other), or a listen address that is not
// local while TLS is not configured. (The TLS files themselves are checked
// when the server starts.) Every CLI11 exception becomes a status.
absl::StatusOr<ParsedArgs> ParseArgs(int argc, const char* const* argv);

// The same as ParseArgs of `hdrstereod --config FILE` with FILE holding
// `toml_text`, read from memory.
absl::StatusOr<ParsedArgs> ParseConfigText(absl::string_view toml_text);

// True for "unix:PATH" and loopback HOST:PORT (localhost, 127.x, [::1]).
bool IsLocalAddress(const std::string& address);

// OK for "unix:PATH" and HOST:PORT; a non-local address needs `tls`.
absl::Status ValidateListenAddress(const std::string& address,
                                   const TlsConfig& tls);
// OK for HOST:PORT; a non-local address needs `tls`.
absl::Status ValidateHttpAddress(const std::string& address,
                                 const TlsConfig& tls);
// INVALID_ARGUMENT unless `address` is empty (metrics off) or a loopback
// HOST:PORT.
absl::Status ValidateMetricsAddress(const std::string& address);

}  // namespace hdrstereo::daemon

#endif  // HDRSTEREO_DAEMON_CONFIG_H_
