#include "ajar/daemon/config.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <set>
#include <sstream>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "ajar/core/geometry.hpp"

namespace ajar::daemon {
namespace {

std::string describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  return "a map";
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0u : 1u)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string format_number(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// A map in the YAML file at a key path. Every value is read through it, so that every error names
// the file, the line, the key path, what was found and what is allowed; finish() rejects keys that
// were never read (typos).
class Section {
 public:
  Section(const YAML::Node& node, std::string path, const std::string& file)
      : node_(node), path_(std::move(path)), file_(file) {
    if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap()) {
      fail(node_, path_, "must be a map of keys", describe(node_), "key: value pairs");
    }
  }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key_path,
                         const std::string& problem, const std::string& got,
                         const std::string& allowed) const {
    std::ostringstream s;
    s << file_;
    if (at.IsDefined() && at.Mark().line >= 0) s << ':' << (at.Mark().line + 1);
    s << ": " << (key_path.empty() ? "(top level)" : key_path) << ": " << problem;
    if (!got.empty() && !allowed.empty()) {
      s << " (got " << got << "; allowed: " << allowed << ')';
    } else if (!got.empty()) {
      s << " (got " << got << ')';
    } else if (!allowed.empty()) {
      s << " (allowed: " << allowed << ')';
    }
    throw ConfigError(s.str());
  }

  std::string key_path(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  }

  YAML::Node raw(std::string_view key) {
    known_.insert(std::string(key));
    if (!node_.IsDefined() || node_.IsNull()) return YAML::Node(YAML::NodeType::Undefined);
    return node_[std::string(key)];
  }

  Section section(std::string_view key) { return Section(raw(key), key_path(key), file_); }

  double number(std::string_view key, double& out, double min, double max, const char* unit = "") {
    const YAML::Node n = raw(key);
    if (!n.IsDefined() || n.IsNull()) return out;
    out = scalar_number(n, key_path(key), min, max, unit);
    return out;
  }

  template <typename Int>
  void integer(std::string_view key, Int& out, long long min, long long max) {
    const YAML::Node n = raw(key);
    if (!n.IsDefined() || n.IsNull()) return;
    long long v = 0;
    try {
      if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "not a scalar");
      v = n.as<long long>();
    } catch (const YAML::Exception&) {
      fail(n, key_path(key), "must be a whole number", describe(n),
           std::to_string(min) + ".." + std::to_string(max));
    }
    if (v < min || v > max) {
      fail(n, key_path(key), "is out of range", describe(n),
           std::to_string(min) + ".." + std::to_string(max));
    }
    out = static_cast<Int>(v);
  }

  void boolean(std::string_view key, bool& out) {
    const YAML::Node n = raw(key);
    if (!n.IsDefined() || n.IsNull()) return;
    try {
      if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "not a scalar");
      out = n.as<bool>();
    } catch (const YAML::Exception&) {
      fail(n, key_path(key), "must be true or false", describe(n), "true, false");
    }
  }

  void text(std::string_view key, std::string& out, bool allow_empty = true) {
    const YAML::Node n = raw(key);
    if (!n.IsDefined() || n.IsNull()) return;
    if (!n.IsScalar()) fail(n, key_path(key), "must be a string", describe(n), "");
    if (!allow_empty && n.Scalar().empty()) {
      fail(n, key_path(key), "must not be empty", describe(n), "a non-empty string");
    }
    out = n.Scalar();
  }

  // One of a fixed set of words.
  template <typename T>
  void choice(std::string_view key, T& out, const std::vector<std::pair<std::string, T>>& table) {
    const YAML::Node n = raw(key);
    if (!n.IsDefined() || n.IsNull()) return;
    std::string allowed;
    for (const auto& [word, value] : table) {
      if (n.IsScalar() && n.Scalar() == word) {
        out = value;
        return;
      }
      allowed += (allowed.empty() ? "" : ", ") + word;
    }
    fail(n, key_path(key), "is not one of the allowed values", describe(n), allowed);
  }

  // A list of exactly `count` numbers.
  std::vector<double> numbers(std::string_view key, std::size_t count, double min, double max) {
    const YAML::Node n = raw(key);
    if (!n.IsDefined() || n.IsNull()) return {};
    if (!n.IsSequence() || n.size() != count) {
      fail(n, key_path(key), "must be a list of " + std::to_string(count) + " numbers",
           describe(n) + (n.IsSequence() ? " of " + std::to_string(n.size()) : ""), "");
    }
    std::vector<double> values;
    for (std::size_t i = 0; i < count; ++i) {
      values.push_back(
          scalar_number(n[i], key_path(key) + "[" + std::to_string(i) + "]", min, max, ""));
    }
    return values;
  }

  // A [min, max] pair with min < max.
  void range(std::string_view key, double& lo, double& hi, double min, double max,
             const char* unit) {
    const auto v = numbers(key, 2, min, max);
    if (v.empty()) return;
    if (!(v[0] < v[1])) {
      fail(raw(key), key_path(key), "must be [min, max] with min < max",
           "[" + format_number(v[0]) + ", " + format_number(v[1]) + "]",
           std::string("an increasing pair in ") + unit);
    }
    lo = v[0];
    hi = v[1];
  }

  // Rejects keys that nothing read: a typo must not silently fall back to a default.
  void finish() const {
    if (!node_.IsDefined() || node_.IsNull()) return;
    for (const auto& entry : node_) {
      const std::string key = entry.first.as<std::string>();
      if (known_.count(key) != 0) continue;
      std::string allowed;
      std::string closest;
      std::size_t best = 3;  // suggest only near misses
      for (const auto& k : known_) {
        allowed += (allowed.empty() ? "" : ", ") + k;
        const std::size_t d = edit_distance(key, k);
        if (d < best) {
          best = d;
          closest = k;
        }
      }
      fail(entry.first, key_path(key),
           "unknown key" + (closest.empty() ? std::string() : " (did you mean '" + closest + "'?)"),
           "'" + key + "'",
           "in " + (path_.empty() ? std::string("the top level") : path_) + ": " + allowed);
    }
  }

  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

 private:
  double scalar_number(const YAML::Node& n, const std::string& where, double min, double max,
                       const char* unit) const {
    double v = 0;
    try {
      if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "not a scalar");
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, where, "must be a number", describe(n),
           format_number(min) + ".." + format_number(max) + unit);
    }
    if (!std::isfinite(v) || v < min || v > max) {
      fail(n, where, std::isfinite(v) ? "is out of range" : "must be finite", describe(n),
           format_number(min) + ".." + format_number(max) + unit);
    }
    return v;
  }

  YAML::Node node_;
  std::string path_;
  const std::string& file_;
  std::set<std::string> known_;
};

constexpr double kHalfPi = std::numbers::pi / 2;

// One identity of network.tls.identities / deny: exactly one of cn, san, sha256.
TlsIdentity read_identity(Section& s) {
  TlsIdentity id;
  int given = 0;
  std::string value;
  if (s.text("cn", value, false), !value.empty()) {
    id = {TlsIdentity::Kind::kCommonName, value};
    ++given;
  }
  value.clear();
  if (s.text("san", value, false), !value.empty()) {
    id = {TlsIdentity::Kind::kSubjectAltName, value};
    ++given;
  }
  value.clear();
  if (s.text("sha256", value, false), !value.empty()) {
    std::string hex;
    for (const char ch : value) {
      if (ch == ':') continue;
      hex += static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    }
    if (hex.size() != 64 || hex.find_first_not_of("0123456789ABCDEF") != std::string::npos) {
      s.fail(s.raw("sha256"), s.key_path("sha256"), "is not a SHA-256 fingerprint",
             "'" + value + "'",
             "64 hex digits, colons optional (openssl x509 -fingerprint -sha256)");
    }
    id = {TlsIdentity::Kind::kSha256, hex};
    ++given;
  }
  if (given != 1) {
    s.fail(s.raw("cn"), s.path(), "must name exactly one of cn, san, sha256",
           std::to_string(given) + " given", "{cn: NAME} or {san: NAME} or {sha256: HEX}");
  }
  return id;
}

void read_tls(Section s, TlsConfig& c) {
  s.boolean("enabled", c.enabled);
  s.text("certificate", c.certificate);
  s.text("private_key", c.private_key);
  s.text("ca", c.ca);
  s.text("crl", c.crl);
  s.number("handshake_timeout_s", c.handshake_timeout_s, 0.1, 600, " s");
  s.integer("max_pending_handshakes", c.max_pending_handshakes, 1, 4096);
  s.choice<bool>("unlisted", c.unlisted_may_observe, {{"observer", true}, {"refuse", false}});
  auto list = [&](std::string_view key, auto&& each) {
    const YAML::Node n = s.raw(key);
    if (!n.IsDefined() || n.IsNull()) return;
    if (!n.IsSequence()) s.fail(n, s.key_path(key), "must be a list", describe(n), "");
    for (std::size_t i = 0; i < n.size(); ++i) {
      Section item(n[i], s.key_path(key) + "[" + std::to_string(i) + "]", s.file());
      each(item);
      item.finish();
    }
  };
  c.identities.clear();
  list("identities", [&](Section& item) {
    TlsGrant grant;
    grant.identity = read_identity(item);
    if (!item.raw("role").IsDefined()) {
      item.fail(item.raw("role"), item.key_path("role"), "is required", "nothing",
                "controller, observer");
    }
    item.choice<bool>("role", grant.may_control, {{"controller", true}, {"observer", false}});
    item.boolean("may_stop", grant.may_stop);
    c.identities.push_back(grant);
  });
  c.deny.clear();
  list("deny", [&](Section& item) { c.deny.push_back(read_identity(item)); });
  s.finish();
  if (!c.enabled) return;
  for (const auto* key : {"certificate", "private_key", "ca"}) {
    const std::string& value = std::string_view(key) == "certificate" ? c.certificate
                               : std::string_view(key) == "ca"        ? c.ca
                                                                      : c.private_key;
    if (value.empty()) {
      s.fail(s.raw(key), s.key_path(key), "is required when network.tls.enabled is true", "nothing",
             "a PEM file path (scripts/make-certs creates them)");
    }
  }
}

void read_network(Section s, NetworkConfig& c) {
  s.text("bind_address", c.bind_address, false);
  {
    unsigned char buf[16];
    if (inet_pton(AF_INET, c.bind_address.c_str(), buf) != 1 &&
        inet_pton(AF_INET6, c.bind_address.c_str(), buf) != 1) {
      s.fail(s.raw("bind_address"), s.key_path("bind_address"), "is not an IP address",
             "'" + c.bind_address + "'", "an IPv4 or IPv6 literal such as 127.0.0.1, 0.0.0.0, ::1");
    }
  }
  s.integer("port", c.port, 0, 65535);
  s.integer("max_clients", c.max_clients, 1, 4096);
  s.integer("send_queue_frames", c.send_queue_frames, 8, 65536);
  s.number("read_deadline_s", c.read_deadline_s, 0.1, 3600, " s");
  s.number("idle_timeout_s", c.idle_timeout_s, 0, 86400, " s (0 = none)");
  s.number("hello_timeout_s", c.hello_timeout_s, 0, 3600, " s (0 = none)");
  s.boolean("insecure_plaintext", c.insecure_plaintext);
  read_tls(s.section("tls"), c.tls);
  s.finish();
  if (!c.tls.enabled && !is_loopback_address(c.bind_address) && !c.insecure_plaintext) {
    s.fail(s.raw("bind_address"), s.key_path("bind_address"),
           "plaintext is only allowed on loopback: enable network.tls (docs/security.md), or "
           "set network.insecure_plaintext: true to accept anyone on the network as an operator",
           "'" + c.bind_address + "'", "127.0.0.1, ::1, or any address with network.tls");
  }
}

void read_frames(Section s, Config& c) {
  const YAML::Node n = s.raw("camera_to_base_m");
  if (n.IsDefined() && !n.IsNull()) {
    const std::string key = s.key_path("camera_to_base_m");
    if (!n.IsSequence() || n.size() != 4) {
      s.fail(n, key, "must be a 4x4 matrix given as 4 rows of 4 numbers", describe(n), "");
    }
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
      const YAML::Node row = n[static_cast<std::size_t>(r)];
      const std::string row_key = key + "[" + std::to_string(r) + "]";
      if (!row.IsSequence() || row.size() != 4) {
        s.fail(row, row_key, "must be a row of 4 numbers", describe(row), "");
      }
      for (int col = 0; col < 4; ++col) {
        const YAML::Node v = row[static_cast<std::size_t>(col)];
        double value = 0;
        try {
          value = v.as<double>();
        } catch (const YAML::Exception&) {
          s.fail(v, row_key + "[" + std::to_string(col) + "]", "must be a number", describe(v), "");
        }
        if (!std::isfinite(value)) {
          s.fail(v, row_key + "[" + std::to_string(col) + "]", "must be finite", describe(v), "");
        }
        m(r, col) = value;
      }
    }
    c.camera_to_base_m = m;
  }
  const auto rigid = core::CameraToBase::from_matrix(c.camera_to_base_m);
  if (!rigid) {
    s.fail(n, s.key_path("camera_to_base_m"),
           "is not a rigid transform: " + rigid.error().message + " [" + rigid.error().field + "]",
           "",
           "a rotation with orthonormal columns and determinant +1, translation in metres, "
           "bottom row 0 0 0 1");
  }
  s.finish();
}

void read_wheel(Section s, core::WheelAxis& w) {
  s.integer("card_axis", w.card_axis, 1, 8);
  s.integer("polarity", w.polarity, -1, 1);
  if (w.polarity == 0) {
    s.fail(s.raw("polarity"), s.key_path("polarity"), "must be +1 or -1", "0", "1, -1");
  }
  s.finish();
}

void read_base(Section s, core::BaseGeometry& b) {
  s.number("wheel_radius_m", b.wheel_radius_m, 0.01, 1.0, " m");
  s.number("turning_radius_m", b.turning_radius_m, 0.05, 2.0, " m");
  s.number("encoder_counts_per_rev", b.encoder_counts_per_rev, 1, 1e7);
  s.number("gear_ratio", b.gear_ratio, 0.01, 1000);
  read_wheel(s.section("left_wheel"), b.left);
  read_wheel(s.section("right_wheel"), b.right);
  if (b.left.card_axis == b.right.card_axis) {
    s.fail(s.raw("right_wheel"), s.key_path("right_wheel.card_axis"),
           "must differ from left_wheel.card_axis", std::to_string(b.right.card_axis),
           "two different card axes");
  }
  s.number("max_wheel_speed_rad_s", b.max_wheel_speed_rad_s, 0.01, 100, " rad/s");
  s.number("max_wheel_accel_rad_s2", b.max_wheel_accel_rad_s2, 0.01, 1000, " rad/s^2");
  s.finish();
}

void read_limits(Section s, core::Limits& l) {
  s.range("door_width_m", l.min_door_width_m, l.max_door_width_m, 0.1, 5.0, " m");
  s.range("handle_length_m", l.min_handle_length_m, l.max_handle_length_m, 0.01, 1.0, " m");
  s.range("depth_m", l.min_depth_m, l.max_depth_m, 0.05, 20.0, " m");
  s.number("max_yaw_correction_rad", l.max_yaw_correction_rad, 0.001, kHalfPi - 1e-3, " rad");
  {
    Section t = s.section("tolerances");
    auto& tol = l.tolerances;
    t.number("min_point_separation_m", tol.min_point_separation_m, 1e-4, 0.5, " m");
    t.number("min_lateral_fraction", tol.min_lateral_fraction, 0.0, 1.0);
    t.number("collinearity", tol.collinearity, 1e-6, 0.5);
    t.number("max_plane_rms_m", tol.max_plane_rms_m, 1e-5, 0.5, " m");
    t.number("max_door_tilt_rad", tol.max_door_tilt_rad, 0.0, kHalfPi - 1e-3, " rad");
    t.finish();
  }
  {
    Section a = s.section("arm_workspace");
    auto& arm = l.arm;
    const auto shoulder = a.numbers("shoulder_m", 3, -5, 5);
    if (!shoulder.empty()) arm.shoulder_m = core::Vec3(shoulder[0], shoulder[1], shoulder[2]);
    a.range("reach_m", arm.min_reach_m, arm.max_reach_m, 0.0, 5.0, " m");
    a.range("z_m", arm.min_z_m, arm.max_z_m, -5.0, 5.0, " m");
    a.finish();
  }
  s.finish();
}

void read_drive(Section s, core::DriveLimits& d) {
  s.number("max_linear_speed_m_s", d.max_linear_speed_m_s, 0.001, 5, " m/s");
  s.number("max_angular_speed_rad_s", d.max_angular_speed_rad_s, 0.001, 10, " rad/s");
  s.number("max_linear_accel_m_s2", d.max_linear_accel_m_s2, 0.001, 20, " m/s^2");
  s.number("max_angular_accel_rad_s2", d.max_angular_accel_rad_s2, 0.001, 50, " rad/s^2");
  s.number("command_timeout_s", d.command_timeout_s, 0.05, 5, " s");
  s.number("approach_max_travel_m", d.approach_max_travel_m, 0.01, 20, " m");
  s.number("approach_square_tolerance_rad", d.approach_square_tolerance_rad, 0.001, 1.0, " rad");
  s.number("approach_min_standoff_m", d.approach_min_standoff_m, 0.05, 10, " m");
  s.number("stale_travel_m", d.stale_travel_m, 0.001, 1.0, " m");
  s.number("stale_yaw_rad", d.stale_yaw_rad, 0.001, 1.0, " rad");
  s.finish();
}

void read_drivers(Section s, drivers::DriverSettings& d) {
  using drivers::DriverKind;
  using drivers::MockFault;
  s.choice<DriverKind>(
      "kind", d.kind,
      {{"sim", DriverKind::kSim}, {"mock", DriverKind::kMock}, {"real", DriverKind::kReal}});
  {
    Section c = s.section("card");
    c.text("library", d.card.library_path);
    c.text("config_file", d.card.card_config_path);
    c.integer("channel", d.card.channel, 0, 15);
    c.integer("poll_timeout_ms", d.card.poll_timeout_ms, 1, 60000);
    c.integer("axis_count", d.card.axis_count, 1, 8);
    c.finish();
    if (d.kind == DriverKind::kReal && d.card.library_path.empty()) {
      c.fail(c.raw("library"), c.key_path("library"), "is required when drivers.kind is real",
             "nothing", "the path of the vendor's GTS library, e.g. /opt/googoltech/lib/libgts.so");
    }
  }
  {
    Section a = s.section("arm");
    a.text("device", d.arm.device, false);
    a.integer("baud", d.arm.baud, 1200, 4000000);
    static const int kStandardBauds[] = {1200,  2400,   4800,   9600,   19200, 38400,
                                         57600, 115200, 230400, 460800, 921600};
    if (std::find(std::begin(kStandardBauds), std::end(kStandardBauds), d.arm.baud) ==
        std::end(kStandardBauds)) {
      a.fail(a.raw("baud"), a.key_path("baud"), "is not a standard baud rate",
             std::to_string(d.arm.baud),
             "1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600");
    }
    a.integer("data_bits", d.arm.data_bits, 5, 8);
    a.choice<char>("parity", d.arm.parity, {{"none", 'N'}, {"even", 'E'}, {"odd", 'O'}});
    a.integer("stop_bits", d.arm.stop_bits, 1, 2);
    a.integer("ack_timeout_ms", d.arm.ack_timeout_ms, 1, 60000);
    a.integer("retries", d.arm.retries, 0, 100);
    a.integer("reconnect_min_ms", d.arm.reconnect_min_ms, 1, 600000);
    a.integer("reconnect_max_ms", d.arm.reconnect_max_ms, 1, 600000);
    if (d.arm.reconnect_max_ms < d.arm.reconnect_min_ms) {
      a.fail(a.raw("reconnect_max_ms"), a.key_path("reconnect_max_ms"),
             "must not be below reconnect_min_ms", std::to_string(d.arm.reconnect_max_ms),
             ">= " + std::to_string(d.arm.reconnect_min_ms));
    }
    a.finish();
  }
  {
    const std::vector<std::pair<std::string, MockFault>> faults = {
        {"off", MockFault::kOff},
        {"stuck", MockFault::kStuck},
        {"slow", MockFault::kSlow},
        {"error", MockFault::kErrorCode},
        {"intermittent", MockFault::kIntermittent},
        {"garbage", MockFault::kGarbage}};
    Section m = s.section("mock");
    m.choice<MockFault>("card_fault", d.mock.card_fault, faults);
    m.choice<MockFault>("arm_fault", d.mock.arm_fault, faults);
    m.integer("slow_ms", d.mock.slow_ms, 0, 60000);
    m.finish();
  }
  {
    Section sim = s.section("sim");
    sim.number("speedup", d.sim_speedup, 0.1, 1000);
    sim.finish();
  }
  s.finish();
}

void read_control(Section s, ControlConfig& c) {
  s.number("rate_hz", c.rate_hz, 10, 5000, " Hz");
  s.boolean("realtime", c.realtime);
  s.integer("priority", c.priority, 1, 99);
  s.boolean("lock_memory", c.lock_memory);
  s.number("motion_timeout_margin_s", c.motion_timeout_margin_s, 0.0, 600, " s");
  s.number("aligned_tolerance_rad", c.aligned_tolerance_rad, 0.0, 0.5, " rad");
  s.finish();
}

void read_logging(Section s, LoggingConfig& c) {
  s.choice<std::string>("level", c.level,
                        {{"trace", "trace"},
                         {"debug", "debug"},
                         {"info", "info"},
                         {"warn", "warn"},
                         {"error", "error"},
                         {"critical", "critical"},
                         {"off", "off"}});
  s.choice<std::string>("sink", c.sink,
                        {{"auto", "auto"}, {"stderr", "stderr"}, {"journald", "journald"}});
  s.finish();
}

}  // namespace

std::string TlsIdentity::text() const {
  switch (kind) {
    case Kind::kCommonName:
      return "cn:" + value;
    case Kind::kSubjectAltName:
      return "san:" + value;
    case Kind::kSha256:
      return "sha256:" + value;
  }
  return value;
}

bool is_loopback_address(const std::string& address) {
  in_addr v4{};
  if (inet_pton(AF_INET, address.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (inet_pton(AF_INET6, address.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6) != 0;
  return false;
}

Config load_config(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open the config file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  Config c;
  c.source_path = path;
  c.camera_to_base_m = core::paper_camera_to_base_m();
  Section top(root, "", path);
  read_network(top.section("network"), c.network);
  read_frames(top.section("frames"), c);
  read_base(top.section("base"), c.base);
  read_limits(top.section("limits"), c.limits);
  read_drive(top.section("drive"), c.drive);
  read_drivers(top.section("drivers"), c.drivers);
  read_control(top.section("control"), c.control);
  {
    Section s = top.section("safety");
    s.number("deadman_timeout_s", c.safety.deadman_timeout_s, 0.02, 60, " s");
    s.number("arm_task_timeout_s", c.safety.arm_task_timeout_s, 0.1, 3600, " s");
    s.finish();
  }
  read_logging(top.section("logging"), c.logging);
  {
    Section s = top.section("state");
    s.text("directory", c.state.directory, false);
    s.finish();
  }
  top.finish();

  // Cross-field checks.
  for (const auto* wheel : {&c.base.left, &c.base.right}) {
    if (wheel->card_axis > c.drivers.card.axis_count) {
      const std::string side = wheel == &c.base.left ? "left_wheel" : "right_wheel";
      top.fail(root["base"], "base." + side + ".card_axis", "is not an axis of the card",
               std::to_string(wheel->card_axis),
               "1.." + std::to_string(c.drivers.card.axis_count) + " (drivers.card.axis_count)");
    }
  }
  if (c.limits.max_depth_m <= c.limits.min_depth_m) {
    top.fail(root["limits"], "limits.depth_m", "must be [min, max] with min < max", "", "");
  }
  return c;
}

namespace {

void emit_range(YAML::Emitter& out, const char* key, double lo, double hi) {
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq << lo << hi
      << YAML::EndSeq;
}

void emit_wheel(YAML::Emitter& out, const char* key, const core::WheelAxis& w) {
  out << YAML::Key << key << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "card_axis" << YAML::Value << w.card_axis;
  out << YAML::Key << "polarity" << YAML::Value << w.polarity;
  out << YAML::EndMap;
}

const char* to_word(drivers::MockFault f) {
  switch (f) {
    case drivers::MockFault::kOff:
      return "off";
    case drivers::MockFault::kStuck:
      return "stuck";
    case drivers::MockFault::kSlow:
      return "slow";
    case drivers::MockFault::kErrorCode:
      return "error";
    case drivers::MockFault::kIntermittent:
      return "intermittent";
    case drivers::MockFault::kGarbage:
      return "garbage";
  }
  return "off";
}

const char* to_word(drivers::DriverKind k) {
  switch (k) {
    case drivers::DriverKind::kSim:
      return "sim";
    case drivers::DriverKind::kMock:
      return "mock";
    case drivers::DriverKind::kReal:
      return "real";
  }
  return "sim";
}

}  // namespace

std::string to_yaml(const Config& c) {
  YAML::Emitter out;
  out.SetDoublePrecision(12);
  out << YAML::BeginMap;
  out << YAML::Key << "network" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "bind_address" << YAML::Value << c.network.bind_address;
  out << YAML::Key << "port" << YAML::Value << c.network.port;
  out << YAML::Key << "max_clients" << YAML::Value << c.network.max_clients;
  out << YAML::Key << "send_queue_frames" << YAML::Value << c.network.send_queue_frames;
  out << YAML::Key << "read_deadline_s" << YAML::Value << c.network.read_deadline_s;
  out << YAML::Key << "idle_timeout_s" << YAML::Value << c.network.idle_timeout_s;
  out << YAML::Key << "hello_timeout_s" << YAML::Value << c.network.hello_timeout_s;
  out << YAML::Key << "insecure_plaintext" << YAML::Value << c.network.insecure_plaintext;
  {
    const auto& t = c.network.tls;
    auto identity = [&out](const TlsIdentity& id) {
      out << YAML::Key
          << (id.kind == TlsIdentity::Kind::kCommonName       ? "cn"
              : id.kind == TlsIdentity::Kind::kSubjectAltName ? "san"
                                                              : "sha256")
          << YAML::Value << id.value;
    };
    out << YAML::Key << "tls" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "enabled" << YAML::Value << t.enabled;
    out << YAML::Key << "certificate" << YAML::Value << t.certificate;
    out << YAML::Key << "private_key" << YAML::Value << t.private_key;
    out << YAML::Key << "ca" << YAML::Value << t.ca;
    out << YAML::Key << "crl" << YAML::Value << t.crl;
    out << YAML::Key << "handshake_timeout_s" << YAML::Value << t.handshake_timeout_s;
    out << YAML::Key << "max_pending_handshakes" << YAML::Value << t.max_pending_handshakes;
    out << YAML::Key << "unlisted" << YAML::Value
        << (t.unlisted_may_observe ? "observer" : "refuse");
    out << YAML::Key << "identities" << YAML::Value << YAML::BeginSeq;
    for (const auto& g : t.identities) {
      out << YAML::Flow << YAML::BeginMap;
      identity(g.identity);
      out << YAML::Key << "role" << YAML::Value << (g.may_control ? "controller" : "observer");
      out << YAML::Key << "may_stop" << YAML::Value << g.may_stop;
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
    out << YAML::Key << "deny" << YAML::Value << YAML::BeginSeq;
    for (const auto& d : t.deny) {
      out << YAML::Flow << YAML::BeginMap;
      identity(d);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;

  out << YAML::Key << "frames" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "camera_to_base_m" << YAML::Value << YAML::BeginSeq;
  for (int r = 0; r < 4; ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (int col = 0; col < 4; ++col)
      out << c.camera_to_base_m(r, col);
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq << YAML::EndMap;

  const auto& b = c.base;
  out << YAML::Key << "base" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "wheel_radius_m" << YAML::Value << b.wheel_radius_m;
  out << YAML::Key << "turning_radius_m" << YAML::Value << b.turning_radius_m;
  out << YAML::Key << "encoder_counts_per_rev" << YAML::Value << b.encoder_counts_per_rev;
  out << YAML::Key << "gear_ratio" << YAML::Value << b.gear_ratio;
  emit_wheel(out, "left_wheel", b.left);
  emit_wheel(out, "right_wheel", b.right);
  out << YAML::Key << "max_wheel_speed_rad_s" << YAML::Value << b.max_wheel_speed_rad_s;
  out << YAML::Key << "max_wheel_accel_rad_s2" << YAML::Value << b.max_wheel_accel_rad_s2;
  out << YAML::EndMap;

  const auto& l = c.limits;
  out << YAML::Key << "limits" << YAML::Value << YAML::BeginMap;
  emit_range(out, "door_width_m", l.min_door_width_m, l.max_door_width_m);
  emit_range(out, "handle_length_m", l.min_handle_length_m, l.max_handle_length_m);
  emit_range(out, "depth_m", l.min_depth_m, l.max_depth_m);
  out << YAML::Key << "max_yaw_correction_rad" << YAML::Value << l.max_yaw_correction_rad;
  out << YAML::Key << "tolerances" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "min_point_separation_m" << YAML::Value
      << l.tolerances.min_point_separation_m;
  out << YAML::Key << "min_lateral_fraction" << YAML::Value << l.tolerances.min_lateral_fraction;
  out << YAML::Key << "collinearity" << YAML::Value << l.tolerances.collinearity;
  out << YAML::Key << "max_plane_rms_m" << YAML::Value << l.tolerances.max_plane_rms_m;
  out << YAML::Key << "max_door_tilt_rad" << YAML::Value << l.tolerances.max_door_tilt_rad;
  out << YAML::EndMap;
  out << YAML::Key << "arm_workspace" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "shoulder_m" << YAML::Value << YAML::Flow << YAML::BeginSeq
      << l.arm.shoulder_m.x() << l.arm.shoulder_m.y() << l.arm.shoulder_m.z() << YAML::EndSeq;
  emit_range(out, "reach_m", l.arm.min_reach_m, l.arm.max_reach_m);
  emit_range(out, "z_m", l.arm.min_z_m, l.arm.max_z_m);
  out << YAML::EndMap << YAML::EndMap;

  const auto& d = c.drivers;
  out << YAML::Key << "drivers" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "kind" << YAML::Value << to_word(d.kind);
  out << YAML::Key << "card" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "library" << YAML::Value << d.card.library_path;
  out << YAML::Key << "config_file" << YAML::Value << d.card.card_config_path;
  out << YAML::Key << "channel" << YAML::Value << d.card.channel;
  out << YAML::Key << "poll_timeout_ms" << YAML::Value << d.card.poll_timeout_ms;
  out << YAML::Key << "axis_count" << YAML::Value << d.card.axis_count;
  out << YAML::EndMap;
  out << YAML::Key << "arm" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "device" << YAML::Value << d.arm.device;
  out << YAML::Key << "baud" << YAML::Value << d.arm.baud;
  out << YAML::Key << "data_bits" << YAML::Value << d.arm.data_bits;
  out << YAML::Key << "parity" << YAML::Value
      << (d.arm.parity == 'E'   ? "even"
          : d.arm.parity == 'O' ? "odd"
                                : "none");
  out << YAML::Key << "stop_bits" << YAML::Value << d.arm.stop_bits;
  out << YAML::Key << "ack_timeout_ms" << YAML::Value << d.arm.ack_timeout_ms;
  out << YAML::Key << "retries" << YAML::Value << d.arm.retries;
  out << YAML::Key << "reconnect_min_ms" << YAML::Value << d.arm.reconnect_min_ms;
  out << YAML::Key << "reconnect_max_ms" << YAML::Value << d.arm.reconnect_max_ms;
  out << YAML::EndMap;
  out << YAML::Key << "mock" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "card_fault" << YAML::Value << to_word(d.mock.card_fault);
  out << YAML::Key << "arm_fault" << YAML::Value << to_word(d.mock.arm_fault);
  out << YAML::Key << "slow_ms" << YAML::Value << d.mock.slow_ms;
  out << YAML::EndMap;
  out << YAML::Key << "sim" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "speedup" << YAML::Value << d.sim_speedup;
  out << YAML::EndMap << YAML::EndMap;

  out << YAML::Key << "drive" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "max_linear_speed_m_s" << YAML::Value << c.drive.max_linear_speed_m_s;
  out << YAML::Key << "max_angular_speed_rad_s" << YAML::Value << c.drive.max_angular_speed_rad_s;
  out << YAML::Key << "max_linear_accel_m_s2" << YAML::Value << c.drive.max_linear_accel_m_s2;
  out << YAML::Key << "max_angular_accel_rad_s2" << YAML::Value << c.drive.max_angular_accel_rad_s2;
  out << YAML::Key << "command_timeout_s" << YAML::Value << c.drive.command_timeout_s;
  out << YAML::Key << "approach_max_travel_m" << YAML::Value << c.drive.approach_max_travel_m;
  out << YAML::Key << "approach_square_tolerance_rad" << YAML::Value
      << c.drive.approach_square_tolerance_rad;
  out << YAML::Key << "approach_min_standoff_m" << YAML::Value << c.drive.approach_min_standoff_m;
  out << YAML::Key << "stale_travel_m" << YAML::Value << c.drive.stale_travel_m;
  out << YAML::Key << "stale_yaw_rad" << YAML::Value << c.drive.stale_yaw_rad;
  out << YAML::EndMap;

  out << YAML::Key << "control" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "rate_hz" << YAML::Value << c.control.rate_hz;
  out << YAML::Key << "realtime" << YAML::Value << c.control.realtime;
  out << YAML::Key << "priority" << YAML::Value << c.control.priority;
  out << YAML::Key << "lock_memory" << YAML::Value << c.control.lock_memory;
  out << YAML::Key << "motion_timeout_margin_s" << YAML::Value << c.control.motion_timeout_margin_s;
  out << YAML::Key << "aligned_tolerance_rad" << YAML::Value << c.control.aligned_tolerance_rad;
  out << YAML::EndMap;

  out << YAML::Key << "safety" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "deadman_timeout_s" << YAML::Value << c.safety.deadman_timeout_s;
  out << YAML::Key << "arm_task_timeout_s" << YAML::Value << c.safety.arm_task_timeout_s;
  out << YAML::EndMap;
  out << YAML::Key << "logging" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "level" << YAML::Value << c.logging.level;
  out << YAML::Key << "sink" << YAML::Value << c.logging.sink;
  out << YAML::EndMap;
  out << YAML::Key << "state" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "directory" << YAML::Value << c.state.directory;
  out << YAML::EndMap;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

namespace {

void collect_changed(const YAML::Node& a, const YAML::Node& b, const std::string& path,
                     std::vector<std::string>& out) {
  if (a.IsMap() && b.IsMap()) {
    for (const auto& entry : a) {
      const auto key = entry.first.as<std::string>();
      collect_changed(entry.second, b[key], path.empty() ? key : path + "." + key, out);
    }
    return;
  }
  if (YAML::Dump(a) != YAML::Dump(b)) out.push_back(path);
}

}  // namespace

std::vector<std::string> changed_keys(const Config& before, const Config& after) {
  std::vector<std::string> out;
  collect_changed(YAML::Load(to_yaml(before)), YAML::Load(to_yaml(after)), "", out);
  return out;
}

}  // namespace ajar::daemon
