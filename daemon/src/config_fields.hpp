// The one list of ajard's config keys (private to config.cpp and config_print.cpp).
//
// fields(io, config) visits every key in file order with its type, its range or words, and its
// unit. Three visitors walk it: the reader (config.cpp: YAML -> Config, every error naming file,
// line and key), the writer (to_yaml) and the key list (config_keys: the flat key/value/allowed
// list that changed_keys compares and the docs/configuration.md test checks). A key added here is
// read, printed, compared and required in the docs at once. Cross-key rules (a wheel's axis within
// the card's axis count, ...) are in check() in config.cpp.
//
// The Io concept (C is Config when reading, const Config otherwise):
//   section(key, fn)                 a map of keys; fn() visits them
//   number(key, v, min, max, unit)   a finite double within [min, max]
//   integer(key, v, min, max)        a whole number within [min, max]
//   integer_of(key, v, set, problem) a whole number from a fixed set
//   boolean(key, v)                  true / false
//   text(key, v, allowed, nonempty)  a string; `allowed` describes it for errors and the docs
//   choice(key, v, words[, presence]) one word of a table (Word<U>[]: config word <-> value)
//   range(key, lo, hi, min, max, unit)  [lo, hi] with min <= lo < hi <= max
//   vector3(key, v, min, max, unit)  three numbers
//   transform(key, m)                a rigid 4x4 transform (4 rows of 4 numbers)
//   list(key, items, allowed, fn)    a list of maps; fn(io, item) visits one item's keys
//   identity(id)                     inside a list item: exactly one of cn, san, sha256
#pragma once

#include <numbers>
#include <span>
#include <sstream>
#include <string>
#include <string_view>

#include "ajar/daemon/config.hpp"

namespace ajar::daemon::config_detail {

// A word of the config file and the value it stands for. Every enum word table exists only here.
template <typename T>
struct Word {
  std::string_view word;
  T value;
};

// Words that are no longer accepted, and what to write instead. `off` (and the `false` a YAML 1.1
// tool such as PyYAML or Ansible writes back for it) means "no fault" / "no logging": `none`.
struct RetiredWord {
  std::string_view word;
  std::string_view replacement;
};
inline constexpr RetiredWord kRetiredWords[] = {{"off", "none"}, {"false", "none"}};
inline constexpr std::string_view kRetiredWhy =
    "YAML 1.1 tools (PyYAML, Ansible) read off as the boolean false and write it back as false";

inline constexpr Word<drivers::DriverKind> kDriverKinds[] = {{"sim", drivers::DriverKind::kSim},
                                                             {"mock", drivers::DriverKind::kMock},
                                                             {"real", drivers::DriverKind::kReal}};

inline constexpr Word<drivers::MockFault> kMockFaults[] = {
    {"none", drivers::MockFault::kNone},
    {"stuck", drivers::MockFault::kStuck},
    {"slow", drivers::MockFault::kSlow},
    {"error", drivers::MockFault::kErrorCode},
    {"intermittent", drivers::MockFault::kIntermittent},
    {"garbage", drivers::MockFault::kGarbage}};
// The mock arm's: the same words, and the arm's own (docs/drivers.md, "The mock arm").
inline constexpr Word<drivers::MockArmFault> kMockArmFaults[] = {
    {"none", drivers::MockArmFault::kNone},
    {"stuck", drivers::MockArmFault::kStuck},
    {"slow", drivers::MockArmFault::kSlow},
    {"error", drivers::MockArmFault::kErrorCode},
    {"intermittent", drivers::MockArmFault::kIntermittent},
    {"garbage", drivers::MockArmFault::kGarbage},
    {"silent_mid_task", drivers::MockArmFault::kSilentMidTask},
    {"silent_mid_stop", drivers::MockArmFault::kSilentMidStop},
    {"reset_mid_task", drivers::MockArmFault::kResetMidTask},
    {"stop_ignored", drivers::MockArmFault::kStopIgnored}};

inline constexpr Word<char> kParities[] = {{"none", 'N'}, {"even", 'E'}, {"odd", 'O'}};

inline constexpr Word<LogLevel> kLogLevels[] = {
    {"trace", LogLevel::kTrace}, {"debug", LogLevel::kDebug}, {"info", LogLevel::kInfo},
    {"warn", LogLevel::kWarn},   {"error", LogLevel::kError}, {"critical", LogLevel::kCritical},
    {"none", LogLevel::kNone}};

inline constexpr Word<LogSink> kLogSinks[] = {
    {"auto", LogSink::kAuto}, {"stderr", LogSink::kStderr}, {"journald", LogSink::kJournald}};

template <typename T, std::size_t N>
constexpr std::string_view word_of(const Word<T> (&words)[N], T value) noexcept {
  for (const auto& w : words) {
    if (w.value == value) return w.word;
  }
  return "?";
}

inline constexpr Word<bool> kUnlisted[] = {{"observer", true}, {"refuse", false}};
inline constexpr Word<bool> kRoles[] = {{"controller", true}, {"observer", false}};

inline constexpr Word<TlsIdentity::Kind> kIdentityKinds[] = {
    {"cn", TlsIdentity::Kind::kCommonName},
    {"san", TlsIdentity::Kind::kSubjectAltName},
    {"sha256", TlsIdentity::Kind::kSha256}};

inline constexpr int kStandardBauds[] = {1200,  2400,   4800,   9600,   19200, 38400,
                                         57600, 115200, 230400, 460800, 921600};
inline constexpr int kPolarities[] = {1, -1};

inline constexpr double kHalfPi = std::numbers::pi / 2;

enum class Text { kMayBeEmpty, kNonEmpty };
enum class Presence { kOptional, kRequired };

template <typename Io, typename C>
void tls_fields(Io& io, C& t) {
  io.boolean("enabled", t.enabled);
  io.text("certificate", t.certificate, "PEM file", Text::kMayBeEmpty);
  io.text("private_key", t.private_key, "PEM file, mode 0600", Text::kMayBeEmpty);
  io.text("ca", t.ca, "PEM file", Text::kMayBeEmpty);
  io.text("crl", t.crl, "PEM file", Text::kMayBeEmpty);
  io.number("handshake_timeout_s", t.handshake_timeout_s, 0.1, 600, "s");
  io.integer("max_pending_handshakes", t.max_pending_handshakes, 1, 4096);
  io.choice("unlisted", t.unlisted_may_observe, kUnlisted);
  io.list("identities", t.identities, "list of {cn, san or sha256; role; may_stop}",
          [](auto& item, auto& grant) {
            item.identity(grant.identity);
            item.choice("role", grant.may_control, kRoles, Presence::kRequired);
            item.boolean("may_stop", grant.may_stop);
          });
  io.list("deny", t.deny, "list of {cn, san or sha256}",
          [](auto& item, auto& identity) { item.identity(identity); });
}

template <typename Io, typename C>
void network_fields(Io& io, C& n) {
  io.text("bind_address", n.bind_address, "IPv4/IPv6 literal", Text::kNonEmpty);
  io.integer("port", n.port, 0, 65535);
  io.integer("max_clients", n.max_clients, 1, 4096);
  io.integer("send_queue_frames", n.send_queue_frames, 8, 65536);
  io.number("read_deadline_s", n.read_deadline_s, 0.1, 3600, "s");
  io.number("idle_timeout_s", n.idle_timeout_s, 0, 86400, "s");
  io.number("hello_timeout_s", n.hello_timeout_s, 0, 3600, "s");
  io.boolean("insecure_plaintext", n.insecure_plaintext);
  io.section("tls", [&] { tls_fields(io, n.tls); });
}

template <typename Io, typename C>
void wheel_fields(Io& io, C& w) {
  io.integer("card_axis", w.card_axis, 1, 8);
  io.integer_of("polarity", w.polarity, kPolarities, "must be +1 or -1");
}

template <typename Io, typename C>
void base_fields(Io& io, C& b) {
  io.number("wheel_radius_m", b.wheel_radius_m, 0.01, 1.0, "m");
  io.number("turning_radius_m", b.turning_radius_m, 0.05, 2.0, "m");
  io.number("encoder_counts_per_rev", b.encoder_counts_per_rev, 1, 1e7, "");
  io.number("gear_ratio", b.gear_ratio, 0.01, 1000, "");
  io.section("left_wheel", [&] { wheel_fields(io, b.left); });
  io.section("right_wheel", [&] { wheel_fields(io, b.right); });
  io.number("max_wheel_speed_rad_s", b.max_wheel_speed_rad_s, 0.01, 100, "rad/s");
  io.number("max_wheel_accel_rad_s2", b.max_wheel_accel_rad_s2, 0.01, 1000, "rad/s^2");
}

template <typename Io, typename C>
void limits_fields(Io& io, C& l) {
  io.range("door_width_m", l.min_door_width_m, l.max_door_width_m, 0.1, 5.0, "m");
  io.range("handle_length_m", l.min_handle_length_m, l.max_handle_length_m, 0.01, 1.0, "m");
  io.range("depth_m", l.min_depth_m, l.max_depth_m, 0.05, 20.0, "m");
  io.number("max_yaw_correction_rad", l.max_yaw_correction_rad, 0.001, kHalfPi - 1e-3, "rad");
  io.section("tolerances", [&] {
    auto& t = l.tolerances;
    io.number("min_point_separation_m", t.min_point_separation_m, 1e-4, 0.5, "m");
    io.number("min_lateral_fraction", t.min_lateral_fraction, 0.0, 1.0, "");
    io.number("collinearity", t.collinearity, 1e-6, 0.5, "");
    io.number("max_plane_rms_m", t.max_plane_rms_m, 1e-5, 0.5, "m");
    io.number("max_door_tilt_rad", t.max_door_tilt_rad, 0.0, kHalfPi - 1e-3, "rad");
  });
  io.section("arm_workspace", [&] {
    auto& a = l.arm;
    io.vector3("shoulder_m", a.shoulder_m, -5, 5, "m");
    io.range("reach_m", a.min_reach_m, a.max_reach_m, 0.0, 5.0, "m");
    io.range("z_m", a.min_z_m, a.max_z_m, -5.0, 5.0, "m");
  });
}

template <typename Io, typename C>
void drive_fields(Io& io, C& d) {
  io.number("max_linear_speed_m_s", d.max_linear_speed_m_s, 0.001, 5, "m/s");
  io.number("max_angular_speed_rad_s", d.max_angular_speed_rad_s, 0.001, 10, "rad/s");
  io.number("max_linear_accel_m_s2", d.max_linear_accel_m_s2, 0.001, 20, "m/s^2");
  io.number("max_angular_accel_rad_s2", d.max_angular_accel_rad_s2, 0.001, 50, "rad/s^2");
  io.number("command_timeout_s", d.command_timeout_s, 0.05, 5, "s");
  io.number("approach_max_travel_m", d.approach_max_travel_m, 0.01, 20, "m");
  io.number("approach_square_tolerance_rad", d.approach_square_tolerance_rad, 0.001, 1.0, "rad");
  io.number("approach_min_standoff_m", d.approach_min_standoff_m, 0.05, 10, "m");
  io.number("stale_forward_speed_m_s", d.stale_forward_speed_m_s, 0.001, 5, "m/s");
  io.number("stale_travel_m", d.stale_travel_m, 0.001, 1.0, "m");
  io.number("stale_yaw_rad", d.stale_yaw_rad, 0.001, 1.0, "rad");
}

template <typename Io, typename C>
void drivers_fields(Io& io, C& d) {
  io.choice("kind", d.kind, kDriverKinds);
  io.section("card", [&] {
    io.text("library", d.card.library_path, "file path", Text::kMayBeEmpty);
    io.text("config_file", d.card.card_config_path, "file path", Text::kMayBeEmpty);
    io.integer("channel", d.card.channel, 0, 15);
    io.integer("poll_timeout_ms", d.card.poll_timeout_ms, 1, 60000);
    io.integer("axis_count", d.card.axis_count, 1, 8);
  });
  io.section("arm", [&] {
    io.text("device", d.arm.device, "device path", Text::kNonEmpty);
    io.integer_of("baud", d.arm.baud, kStandardBauds, "is not a standard baud rate");
    io.integer("data_bits", d.arm.data_bits, 5, 8);
    io.choice("parity", d.arm.parity, kParities);
    io.integer("stop_bits", d.arm.stop_bits, 1, 2);
    io.integer("ack_timeout_ms", d.arm.ack_timeout_ms, 1, 60000);
    io.integer("retries", d.arm.retries, 0, 100);
    io.integer("reconnect_min_ms", d.arm.reconnect_min_ms, 1, 600000);
    io.integer("reconnect_max_ms", d.arm.reconnect_max_ms, 1, 600000);
  });
  io.section("mock", [&] {
    io.choice("card_fault", d.mock.card_fault, kMockFaults);
    io.choice("arm_fault", d.mock.arm_fault, kMockArmFaults);
    io.integer("slow_ms", d.mock.slow_ms, 0, 60000);
  });
  io.section("sim", [&] { io.number("speedup", d.sim_speedup, 0.1, 1000, ""); });
}

template <typename Io, typename C>
void control_fields(Io& io, C& c) {
  io.number("rate_hz", c.rate_hz, 10, 5000, "Hz");
  io.boolean("realtime", c.realtime);
  io.integer("priority", c.priority, 1, 99);
  io.boolean("lock_memory", c.lock_memory);
  io.number("motion_timeout_margin_s", c.motion_timeout_margin_s, 0.0, 600, "s");
  io.number("aligned_tolerance_rad", c.aligned_tolerance_rad, 0.0, 0.5, "rad");
  io.number("stall_timeout_s", c.stall_timeout_s, 0.005, 0.5, "s");
}

// Every key of the file, in the order of config/ajard.yaml and docs/configuration.md.
template <typename Io, typename C>
void fields(Io& io, C& c) {
  io.section("network", [&] { network_fields(io, c.network); });
  io.section("frames", [&] { io.transform("camera_to_base_m", c.camera_to_base_m); });
  io.section("base", [&] { base_fields(io, c.base); });
  io.section("limits", [&] { limits_fields(io, c.limits); });
  io.section("drive", [&] { drive_fields(io, c.drive); });
  io.section("drivers", [&] { drivers_fields(io, c.drivers); });
  io.section("control", [&] { control_fields(io, c.control); });
  io.section("safety", [&] {
    io.number("deadman_timeout_s", c.safety.deadman_timeout_s, 0.02, 60, "s");
    io.number("arm_task_timeout_s", c.safety.arm_task_timeout_s, 0.1, 3600, "s");
    io.number("arm_stop_timeout_s", c.safety.arm_stop_timeout_s, 0.1, 600, "s");
  });
  io.section("logging", [&] {
    io.choice("level", c.logging.level, kLogLevels);
    io.choice("sink", c.logging.sink, kLogSinks);
  });
  io.section("state",
             [&] { io.text("directory", c.state.directory, "directory path", Text::kNonEmpty); });
  io.section("recorder", [&] {
    io.boolean("enabled", c.recorder.enabled);
    io.text("directory", c.recorder.directory, "directory path", Text::kNonEmpty);
    io.integer("max_bytes", c.recorder.max_bytes, 1LL << 20, 1LL << 50);
    io.integer("max_file_bytes", c.recorder.max_file_bytes, 64LL << 10, 1LL << 40);
    io.number("max_file_s", c.recorder.max_file_s, 1, 86400, "s");
    io.integer("loop_decimation", c.recorder.loop_decimation, 1, 10000);
  });
}

// "a, b, c" of text(item) for every item.
std::string join(const auto& items, auto&& text) {
  std::string out;
  for (const auto& item : items)
    out += (out.empty() ? "" : ", ") + std::string(text(item));
  return out;
}

inline std::string format_number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// What errors and docs/configuration.md say a number may be: "0.1..3600 s".
inline std::string limits_text(double min, double max, std::string_view unit) {
  std::ostringstream s;
  s << min << ".." << max;
  if (!unit.empty()) s << ' ' << unit;
  return s.str();
}

// The config word of `value` in `words` (the first word if none matches: cannot happen for a
// value that came from the table).
template <typename T, typename U, std::size_t N>
std::string_view word_of(const T& value, const Word<U> (&words)[N]) {
  for (const auto& w : words) {
    if (value == w.value) return w.word;
  }
  return words[0].word;
}

}  // namespace ajar::daemon::config_detail
