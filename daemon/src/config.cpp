// Reading ajard's config: YAML -> Config through the key list in config_fields.hpp, then the
// cross-key rules (check). Every error is one line naming file, line, key path, value, allowed.
#include "ajar/daemon/config.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "ajar/core/geometry.hpp"
#include "config_fields.hpp"

namespace ajar::daemon {
namespace {

using namespace config_detail;

std::string describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  return "a map";
}

bool given(const YAML::Node& node) {
  return node.IsDefined() && !node.IsNull();
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

// YAML -> Config. One Frame per open map: the keys read in it, so that finish() can refuse a key
// nothing read (a typo must not silently fall back to a default).
class Reader {
 public:
  Reader(const YAML::Node& root, const std::string& file) : file_(file) {
    frames_.push_back({root, ""});
    open(frames_.back());
  }

  // ---- the Io concept (config_fields.hpp) ----

  template <typename Fn>
  void section(std::string_view key, Fn&& fn) {
    frames_.push_back({raw(key), path(key)});
    open(frames_.back());
    fn();
    finish();
    frames_.pop_back();
  }

  void number(Key key, double& out, double min, double max, std::string_view unit) {
    if (const YAML::Node n = raw(key); given(n)) out = scalar_number(n, path(key), min, max, unit);
  }

  template <typename Int>
  void integer(Key key, Int& out, long long min, long long max) {
    const YAML::Node n = raw(key);
    if (!given(n)) return;
    const std::string allowed = std::to_string(min) + ".." + std::to_string(max);
    const long long v = whole_number(n, key, allowed);
    if (v < min || v > max) fail(n, path(key), "is out of range", describe(n), allowed);
    out = static_cast<Int>(v);
  }

  void integer_of(Key key, int& out, std::span<const int> set, std::string_view problem) {
    const YAML::Node n = raw(key);
    if (!given(n)) return;
    const std::string allowed = join(set, [](int v) { return std::to_string(v); });
    const long long v = whole_number(n, key, allowed);
    if (std::find(set.begin(), set.end(), v) == set.end()) {
      fail(n, path(key), std::string(problem), describe(n), allowed);
    }
    out = static_cast<int>(v);
  }

  void boolean(Key key, bool& out) {
    const YAML::Node n = raw(key);
    if (!given(n)) return;
    try {
      if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "not a scalar");
      out = n.as<bool>();
    } catch (const YAML::Exception&) {
      fail(n, path(key), "must be true or false", describe(n), "true, false");
    }
  }

  void text(Key key, std::string& out, std::string_view allowed, Text rule) {
    const YAML::Node n = raw(key);
    if (!given(n)) return;
    if (!n.IsScalar()) fail(n, path(key), "must be a string", describe(n), std::string(allowed));
    if (rule == Text::kNonEmpty && n.Scalar().empty()) {
      fail(n, path(key), "must not be empty", describe(n), std::string(allowed));
    }
    out = n.Scalar();
  }

  template <typename T, typename U, std::size_t N>
  void choice(Key key, T& out, const Word<U> (&words)[N], Presence presence = Presence::kOptional) {
    const YAML::Node n = raw(key);
    const std::string allowed = join(words, [](const auto& w) { return w.word; });
    if (!given(n) && presence == Presence::kRequired) {
      fail(frame().node, path(key), "is required", "nothing", allowed);
    }
    if (!given(n)) return;
    for (const auto& w : words) {
      if (n.IsScalar() && n.Scalar() == w.word) {
        out = T(w.value);
        return;
      }
    }
    std::string problem = "is not one of the allowed values";
    for (const auto& retired : kRetiredWords) {
      const bool offered = std::any_of(std::begin(words), std::end(words), [&](const auto& w) {
        return w.word == retired.replacement;
      });
      if (offered && n.IsScalar() && n.Scalar() == retired.word) {
        problem = "means '" + std::string(retired.replacement) + "', which is its spelling now (" +
                  std::string(kRetiredWhy) + ")";
      }
    }
    fail(n, path(key), problem, describe(n), allowed);
  }

  void range(Key key, double& lo, double& hi, double min, double max, std::string_view unit) {
    const auto v = numbers(key, 2, min, max, unit);
    if (v.empty()) return;
    if (!(v[0] < v[1])) {
      fail(raw(key), path(key), "must be [min, max] with min < max",
           "[" + format_number(v[0]) + ", " + format_number(v[1]) + "]",
           "an increasing pair in " + limits_text(min, max, unit));
    }
    lo = v[0];
    hi = v[1];
  }

  void vector3(Key key, core::Vec3& out, double min, double max, std::string_view unit) {
    const auto v = numbers(key, 3, min, max, unit);
    if (!v.empty()) out = core::Vec3(v[0], v[1], v[2]);
  }

  void transform(Key key, Eigen::Matrix4d& out) {
    const YAML::Node n = raw(key);
    if (!given(n)) return;
    if (!n.IsSequence() || n.size() != 4) {
      fail(n, path(key), "must be a 4x4 matrix given as 4 rows of 4 numbers", describe(n), "");
    }
    for (std::size_t r = 0; r < 4; ++r) {
      const std::string row_path = path(key) + "[" + std::to_string(r) + "]";
      const YAML::Node row = n[r];
      if (!row.IsSequence() || row.size() != 4) {
        fail(row, row_path, "must be a row of 4 numbers", describe(row), "");
      }
      for (std::size_t col = 0; col < 4; ++col) {
        out(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(col)) =
            scalar_number(row[col], row_path + "[" + std::to_string(col) + "]", -1e6, 1e6, "");
      }
    }
  }

  template <typename T, typename Fn>
  void list(Key key, std::vector<T>& items, std::string_view allowed, Fn&& each) {
    const YAML::Node n = raw(key);
    if (!given(n)) return;
    if (!n.IsSequence()) fail(n, path(key), "must be a list", describe(n), std::string(allowed));
    items.clear();
    for (std::size_t i = 0; i < n.size(); ++i) {
      frames_.push_back({n[i], path(key) + "[" + std::to_string(i) + "]"});
      open(frames_.back());
      each(*this, items.emplace_back());
      finish();
      frames_.pop_back();
    }
  }

  // Exactly one of cn, san, sha256 (a fingerprint: 64 hex digits, colons optional, stored upper
  // case without colons).
  void identity(TlsIdentity& id) {
    int count = 0;
    for (const auto& k : kIdentityKinds) {
      std::string value;
      text(k.word, value, "a name", Text::kNonEmpty);
      if (!given(raw(k.word))) continue;
      ++count;
      id = {k.value, value};
    }
    if (count != 1) {
      fail(frame().node, frame().path, "must name exactly one of cn, san, sha256",
           std::to_string(count) + " given", "{cn: NAME} or {san: NAME} or {sha256: HEX}");
    }
    if (id.kind != TlsIdentity::Kind::kSha256) return;
    std::string hex;
    for (const char ch : id.value) {
      if (ch != ':') hex += static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    }
    if (hex.size() != 64 || hex.find_first_not_of("0123456789ABCDEF") != std::string::npos) {
      fail(raw("sha256"), path("sha256"), "is not a SHA-256 fingerprint", "'" + id.value + "'",
           "64 hex digits, colons optional (openssl x509 -fingerprint -sha256)");
    }
    id.value = hex;
  }

  // ---- for check() ----

  // The node at a dotted key path from the top ("base.left_wheel"), or the deepest one given.
  YAML::Node at(std::string_view dotted) const {
    YAML::Node node = frames_.front().node;
    std::size_t start = 0;
    while (start <= dotted.size()) {
      const std::size_t dot = std::min(dotted.find('.', start), dotted.size());
      const YAML::Node& parent = node;
      if (!parent.IsMap()) break;
      const YAML::Node child = parent[std::string(dotted.substr(start, dot - start))];
      if (!given(child)) break;
      node.reset(child);  // rebinds (operator= would overwrite the node in the tree)
      start = dot + 1;
    }
    return node;
  }

  [[noreturn]] void fail_at(std::string_view key_path, const std::string& problem,
                            const std::string& got, const std::string& allowed) const {
    fail(at(key_path), std::string(key_path), problem, got, allowed);
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

  void finish_top() { finish(); }

 private:
  struct Frame {
    YAML::Node node;
    std::string path;
    std::set<std::string, std::less<>> known{};
  };

  Frame& frame() { return frames_.back(); }

  std::string path(std::string_view key) const {
    const std::string& p = frames_.back().path;
    return p.empty() ? std::string(key) : p + "." + std::string(key);
  }

  YAML::Node raw(std::string_view key) {
    frame().known.insert(std::string(key));
    const YAML::Node& node = frame().node;
    if (!given(node)) return YAML::Node(YAML::NodeType::Undefined);
    return node[std::string(key)];
  }

  // A map (or nothing); no key twice (yaml-cpp would keep the first silently).
  void open(const Frame& f) const {
    if (!given(f.node)) return;
    if (!f.node.IsMap()) fail(f.node, f.path, "must be a map of keys", describe(f.node), "");
    std::map<std::string, YAML::Mark> seen;
    for (const auto& entry : f.node) {
      const std::string key = entry.first.Scalar();
      const auto [it, fresh] = seen.emplace(key, entry.first.Mark());
      if (!fresh) {
        fail(entry.first, f.path.empty() ? key : f.path + "." + key,
             "is given twice (lines " + std::to_string(it->second.line + 1) + " and " +
                 std::to_string(entry.first.Mark().line + 1) + "); yaml-cpp would keep one",
             "", "each key once");
      }
    }
  }

  void finish() const {
    const Frame& f = frames_.back();
    if (!given(f.node)) return;
    for (const auto& entry : f.node) {
      const std::string key = entry.first.as<std::string>();
      if (f.known.count(key) != 0) continue;
      std::string closest;
      std::size_t best = 3;  // suggest only near misses
      for (const auto& k : f.known) {
        if (const std::size_t d = edit_distance(key, k); d < best) {
          best = d;
          closest = k;
        }
      }
      fail(entry.first, f.path.empty() ? key : f.path + "." + key,
           "unknown key" + (closest.empty() ? std::string() : " (did you mean '" + closest + "'?)"),
           "'" + key + "'",
           "in " + (f.path.empty() ? std::string("the top level") : f.path) + ": " +
               join(f.known, [](const std::string& k) { return k; }));
    }
  }

  long long whole_number(const YAML::Node& n, std::string_view key, const std::string& allowed) {
    try {
      if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "not a scalar");
      return n.as<long long>();
    } catch (const YAML::Exception&) {
      fail(n, path(key), "must be a whole number", describe(n), allowed);
    }
  }

  double scalar_number(const YAML::Node& n, const std::string& where, double min, double max,
                       std::string_view unit) const {
    double v = 0;
    try {
      if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "not a scalar");
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, where, "must be a number", describe(n), limits_text(min, max, unit));
    }
    if (!std::isfinite(v) || v < min || v > max) {
      fail(n, where, std::isfinite(v) ? "is out of range" : "must be finite", describe(n),
           limits_text(min, max, unit));
    }
    return v;
  }

  // A list of exactly `count` numbers, each within [min, max]; empty when the key is not given.
  std::vector<double> numbers(std::string_view key, std::size_t count, double min, double max,
                              std::string_view unit) {
    const YAML::Node n = raw(key);
    if (!given(n)) return {};
    if (!n.IsSequence() || n.size() != count) {
      fail(n, path(key), "must be a list of " + std::to_string(count) + " numbers",
           describe(n) + (n.IsSequence() ? " of " + std::to_string(n.size()) : ""), "");
    }
    std::vector<double> values;
    for (std::size_t i = 0; i < count; ++i) {
      values.push_back(
          scalar_number(n[i], path(key) + "[" + std::to_string(i) + "]", min, max, unit));
    }
    return values;
  }

  const std::string& file_;
  std::vector<Frame> frames_;
};

bool is_ip_literal(const std::string& address) {
  unsigned char buf[16];
  return inet_pton(AF_INET, address.c_str(), buf) == 1 ||
         inet_pton(AF_INET6, address.c_str(), buf) == 1;
}

// The rules between keys (and of values beyond their type and range), after every key is read.
void check(const Config& c, const Reader& r) {
  const auto& n = c.network;
  if (!is_ip_literal(n.bind_address)) {
    r.fail_at("network.bind_address", "is not an IP address", "'" + n.bind_address + "'",
              "an IPv4 or IPv6 literal such as 127.0.0.1, 0.0.0.0, ::1");
  }
  if (n.tls.enabled) {
    for (const auto& [key, value] :
         {std::pair{"certificate", &n.tls.certificate},
          std::pair{"private_key", &n.tls.private_key}, std::pair{"ca", &n.tls.ca}}) {
      if (value->empty()) {
        r.fail_at(std::string("network.tls.") + key, "is required when network.tls.enabled is true",
                  "nothing", "a PEM file path (scripts/make-certs creates them)");
      }
    }
  }
  if (!n.tls.enabled && !is_loopback_address(n.bind_address) && !n.insecure_plaintext) {
    r.fail_at("network.bind_address",
              "plaintext is only allowed on loopback: enable network.tls (docs/security.md), or "
              "set network.insecure_plaintext: true to accept anyone on the network as an operator",
              "'" + n.bind_address + "'", "127.0.0.1, ::1, or any address with network.tls");
  }
  if (const auto rigid = core::CameraToBase::from_matrix(c.camera_to_base_m); !rigid) {
    r.fail_at(
        "frames.camera_to_base_m",
        "is not a rigid transform: " + rigid.error().message + " [" + rigid.error().field + "]", "",
        "a rotation with orthonormal columns and determinant +1, translation in metres, "
        "bottom row 0 0 0 1");
  }
  if (c.base.left.card_axis == c.base.right.card_axis) {
    r.fail_at("base.right_wheel.card_axis", "must differ from left_wheel.card_axis",
              std::to_string(c.base.right.card_axis), "two different card axes");
  }
  const auto& d = c.drivers;
  if (d.kind == drivers::DriverKind::kReal && d.card.library_path.empty()) {
    r.fail_at("drivers.card.library", "is required when drivers.kind is real", "nothing",
              "the path of the vendor's GTS library, e.g. /opt/googoltech/lib/libgts.so");
  }
  if (d.arm.reconnect_max_ms < d.arm.reconnect_min_ms) {
    r.fail_at("drivers.arm.reconnect_max_ms", "must not be below reconnect_min_ms",
              std::to_string(d.arm.reconnect_max_ms),
              ">= " + std::to_string(d.arm.reconnect_min_ms));
  }
  for (const auto& [side, wheel] :
       {std::pair{"left_wheel", &c.base.left}, std::pair{"right_wheel", &c.base.right}}) {
    if (wheel->card_axis > d.card.axis_count) {
      r.fail_at(std::string("base.") + side + ".card_axis", "is not an axis of the card",
                std::to_string(wheel->card_axis),
                "1.." + std::to_string(d.card.axis_count) + " (drivers.card.axis_count)");
    }
  }
  if (c.recorder.max_file_bytes > c.recorder.max_bytes) {
    r.fail_at("recorder.max_file_bytes", "must not be above recorder.max_bytes",
              std::to_string(c.recorder.max_file_bytes),
              "<= " + std::to_string(c.recorder.max_bytes));
  }
}

YAML::Node load_yaml(const std::string& path) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open the config file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
}

}  // namespace

std::string TlsIdentity::text() const {
  return std::string(
             word_of(config_detail::kIdentityKinds, kind, config_detail::kIdentityKinds[0].word)) +
         ":" + value;
}

bool is_loopback_address(const std::string& address) {
  in_addr v4{};
  if (inet_pton(AF_INET, address.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (inet_pton(AF_INET6, address.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6) != 0;
  return false;
}

std::string_view to_string(LogLevel level) noexcept {
  return word_of(kLogLevels, level, "?");
}

std::string_view to_string(LogSink sink) noexcept {
  return word_of(kLogSinks, sink, "?");
}

Config default_config() {
  Config c;
  c.camera_to_base_m = core::paper_camera_to_base_m();
  return c;
}

Config load_config(const std::string& path) {
  const YAML::Node root = load_yaml(path);
  Config c = default_config();
  c.source_path = path;
  Reader reader(root, path);
  fields(reader, c);
  reader.finish_top();
  check(c, reader);
  return c;
}

}  // namespace ajar::daemon
