// ajard's configuration: one typed struct, loaded and validated in one place. The keys are listed
// once (daemon/src/config_fields.hpp) for reading, printing, comparing and the reference in
// docs/configuration.md (a test checks it against config_keys()). config/ajard.yaml is the default
// (simulated hardware), config/ajard.robot.yaml the example for the real robot.
// Library ajar_config: needs core, the drivers' settings header and yaml-cpp; no sockets, threads
// or logging, so that ajarctl (simulate) reads ajard's config with the daemon's own rules.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "ajar/core/robot_model.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::daemon {

// Thrown for any config mistake. what() is one line: "FILE: KEY.PATH: problem (got VALUE; allowed
// ...)", so an operator can fix it without reading code.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Thrown by start-up (drivers, socket, state directory) with a message naming what failed.
class StartupError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A certificate identity in network.tls.identities / deny (docs/security.md).
struct TlsIdentity {
  enum class Kind { kCommonName, kSubjectAltName, kSha256 };
  Kind kind = Kind::kCommonName;
  std::string value;         // kSha256: 64 upper-case hex digits, no colons
  std::string text() const;  // "cn:alice", "san:host.site", "sha256:AB12..."
};

// What a certificate identity may do.
struct TlsGrant {
  TlsIdentity identity;
  bool may_control = false;  // role controller (may take control); observer otherwise
  bool may_stop = true;      // may send Stop / EmergencyStop (safety: default yes)
};

// network.tls: mutual TLS 1.3 (docs/security.md). crl, identities, deny and unlisted are re-read
// on SIGHUP; the rest needs a restart.
struct TlsConfig {
  bool enabled = false;
  std::string certificate;  // the daemon's certificate chain (PEM)
  std::string private_key;  // its key (PEM); refused when group/world accessible
  std::string ca;           // CA certificate(s) client certificates must chain to (PEM)
  std::string crl;          // optional CRL file (PEM) of that CA: revoked client certificates
  double handshake_timeout_s = 5.0;
  int max_pending_handshakes = 16;   // beyond: the oldest unfinished handshake is dropped
  bool unlisted_may_observe = true;  // a CA-signed certificate not in `identities`: observer
  std::vector<TlsGrant> identities;  // first match wins
  std::vector<TlsIdentity> deny;     // refused at the handshake even though CA-signed
};

struct NetworkConfig {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 7450;
  int max_clients = 300;
  int send_queue_frames = 512;    // per session; a client that lets it fill is dropped
  double read_deadline_s = 10.0;  // a started frame must complete within this
  double idle_timeout_s = 0;      // 0 = none (observers may stay idle forever)
  double hello_timeout_s = 5.0;   // an un-greeted session is closed after this (0 = never)
  // Plaintext off loopback is refused at start unless this is true (then warned at every start).
  bool insecure_plaintext = false;
  TlsConfig tls;
};

// True for 127.0.0.0/8 and ::1 (an IP literal; anything else is false).
bool is_loopback_address(const std::string& address);

struct ControlConfig {
  double rate_hz = 500;   // control loop rate
  bool realtime = false;  // try SCHED_FIFO at `priority`; warn and fall back if refused
  int priority = 80;
  bool lock_memory = false;              // try mlockall (realtime.hpp: what is locked)
  double motion_timeout_margin_s = 2.0;  // deadline = planned duration * 1.5 + margin
  double aligned_tolerance_rad = 0.01;   // a re-measured plane within this counts as aligned
  double stall_timeout_s = 0.1;  // no loop cycle for this long -> the supervisor stops the base
};

struct SafetyConfig {
  double deadman_timeout_s = 0.5;   // controller silent this long during motion -> stop + fault
  double arm_task_timeout_s = 120;  // an arm task not done within this -> arm stop + ARM_TIMEOUT
  double arm_stop_timeout_s = 2.0;  // an arm stop not confirmed (idle) within this -> ARM_NOT_CLEAR
};

// logging.level: trace | debug | info | warn | error | critical | none (nothing is logged).
enum class LogLevel : std::uint8_t { kTrace, kDebug, kInfo, kWarn, kError, kCritical, kNone };
// logging.sink: auto (journald under systemd, else stderr) | stderr | journald.
enum class LogSink : std::uint8_t { kAuto, kStderr, kJournald };
// The config word of a value ("none", "journald"), from the one word table (config_fields.hpp).
std::string_view to_string(LogLevel level) noexcept;
std::string_view to_string(LogSink sink) noexcept;

struct LoggingConfig {
  LogLevel level = LogLevel::kInfo;
  LogSink sink = LogSink::kAuto;
};

struct StateConfig {
  std::string directory = "state";  // accepted parameters are persisted here (relative to cwd)
  // Test and benchmark hook, NOT a config-file key: each save waits this long before its fsync
  // (models slow flash). Always 0 when loaded from a file.
  int debug_write_delay_ms = 0;
};

// The black box (docs/blackbox.md; recorder/include/ajar/recorder/recorder.hpp).
struct RecorderConfig {
  bool enabled = true;
  std::string directory = "recordings";  // relative paths are relative to the working directory
  std::int64_t max_bytes = 512LL << 20;  // every recording but the saved ones
  std::int64_t max_file_bytes = 64LL << 20;
  double max_file_s = 600;
  int loop_decimation = 5;  // every n-th control-loop cycle (1: all)
  // Test and benchmark hook, NOT a config-file key: every write to a recording waits this long
  // first (a slow disk). Always 0 when loaded from a file.
  int debug_write_delay_ms = 0;
};

struct Config {
  std::string source_path;  // the file it was loaded from
  NetworkConfig network;
  // ^B_C T in metres. default_config() and load_config() start from the paper's eq. 2.
  Eigen::Matrix4d camera_to_base_m = Eigen::Matrix4d::Identity();
  core::BaseGeometry base;
  core::Limits limits;
  core::DriveLimits drive;  // jog and approach limits, staleness thresholds
  drivers::DriverSettings drivers;
  ControlConfig control;
  SafetyConfig safety;
  LoggingConfig logging;
  StateConfig state;
  RecorderConfig recorder;
};

// What every key that a file does not give takes (Config{} with the paper's camera transform).
Config default_config();

// Loads and validates `path`. Throws ConfigError naming the file, the line, the key path, the bad
// value and what is allowed: unknown keys (typos), a key or section given twice, wrong types,
// out-of-range values, retired words (`off`: now `none`), a non-rigid transform.
Config load_config(const std::string& path);

// The effective config as YAML (every key, defaults filled in), for --check-config.
std::string to_yaml(const Config& config);

// One key of the file: its dotted path ("drivers.arm.baud"), its value as flow YAML ("115200",
// "[0.5, 2]", "\"\""), what is allowed ("0.1..3600 s", "sim, mock, real", "PEM file") and what it
// means (docs/configuration.md's meaning column, markdown).
struct ConfigKey {
  std::string path;
  std::string value;
  std::string allowed;
  std::string meaning;
};

// Every key in file order with its value in `config`. A list value (a range, the transform, the
// TLS identities) is one key. config_keys(default_config()) is the reference table.
std::vector<ConfigKey> config_keys(const Config& config);

// The keys (dotted paths as in to_yaml, e.g. "logging.level", "base.left_wheel.card_axis") whose
// values differ between two configs, in to_yaml's order. A list value (a range, the transform)
// is one key. For SIGHUP: which changed keys were applied and which need a restart.
std::vector<std::string> changed_keys(const Config& before, const Config& after);

}  // namespace ajar::daemon
