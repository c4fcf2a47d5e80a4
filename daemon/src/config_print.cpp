// Printing ajard's config (to_yaml), its flat key list (config_keys) and the difference of two
// (changed_keys), all through the key list in config_fields.hpp.
#include <yaml-cpp/yaml.h>

#include "ajar/daemon/config.hpp"
#include "config_fields.hpp"

namespace ajar::daemon {
namespace {

using namespace config_detail;

constexpr int kDoublePrecision = 12;  // to_yaml's numbers read back to the same double

// Values as YAML (a range, a point and the transform as flow lists).
void put(YAML::Emitter& out, double v) {
  out << v;
}
void put(YAML::Emitter& out, long long v) {
  out << v;
}
void put(YAML::Emitter& out, bool v) {
  out << v;
}
void put(YAML::Emitter& out, std::string_view v) {
  out << std::string(v);
}
void put(YAML::Emitter& out, double lo, double hi) {
  out << YAML::Flow << YAML::BeginSeq << lo << hi << YAML::EndSeq;
}
void put(YAML::Emitter& out, const core::Vec3& v) {
  out << YAML::Flow << YAML::BeginSeq << v.x() << v.y() << v.z() << YAML::EndSeq;
}
void put(YAML::Emitter& out, const Eigen::Matrix4d& m) {
  out << YAML::BeginSeq;
  for (Eigen::Index r = 0; r < 4; ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (Eigen::Index col = 0; col < 4; ++col)
      out << m(r, col);
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq;
}

// Config -> YAML, every key (the Io concept of config_fields.hpp over const values). Every value
// goes through value(key, args...) -> put(out, args...).
class Writer {
 public:
  explicit Writer(YAML::Emitter& out) : out_(out) {}

  template <typename Fn>
  void section(std::string_view key, Fn&& fn) {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::BeginMap;
    fn();
    out_ << YAML::EndMap;
  }
  void number(Key key, double v, double, double, std::string_view) { value(key, v); }
  void integer(Key key, long long v, long long, long long) { value(key, v); }
  void integer_of(Key key, long long v, auto, std::string_view) { value(key, v); }
  void boolean(Key key, bool v) { value(key, v); }
  void text(Key key, std::string_view v, std::string_view, Text) { value(key, v); }
  template <typename T, typename U, std::size_t N>
  void choice(Key key, const T& v, const Word<U> (&words)[N], Presence = Presence::kOptional) {
    value(key, word_of(words, v, words[0].word));
  }
  void range(Key key, double lo, double hi, double, double, std::string_view) {
    value(key, lo, hi);
  }
  void vector3(Key key, const core::Vec3& v, double, double, std::string_view) { value(key, v); }
  void transform(Key key, const Eigen::Matrix4d& m) { value(key, m); }
  template <typename T, typename Fn>
  void list(Key key, const std::vector<T>& items, std::string_view, Fn&& each) {
    out_ << YAML::Key << std::string(key) << YAML::Value;
    items_of(items, each);
  }
  void identity(const TlsIdentity& id) {
    value(word_of(kIdentityKinds, id.kind, kIdentityKinds[0].word), id.value);
  }

  // A list of maps, each on one line.
  template <typename T, typename Fn>
  void items_of(const std::vector<T>& items, Fn&& each) {
    out_ << YAML::BeginSeq;
    for (const auto& item : items) {
      out_ << YAML::Flow << YAML::BeginMap;
      each(*this, item);
      out_ << YAML::EndMap;
    }
    out_ << YAML::EndSeq;
  }

 private:
  template <typename... V>
  void value(Key key, const V&... v) {
    out_ << YAML::Key << std::string(key) << YAML::Value;
    put(out_, v...);
  }

  YAML::Emitter& out_;
};

// Config -> the flat list of keys, values and what is allowed (the Io concept over const values).
class KeyList {
 public:
  std::vector<ConfigKey> keys;

  template <typename Fn>
  void section(std::string_view key, Fn&& fn) {
    const std::size_t length = prefix_.size();
    prefix_ += std::string(key) + ".";
    fn();
    prefix_.resize(length);
  }
  void number(Key key, double v, double min, double max, std::string_view unit) {
    add(key, limits_text(min, max, unit), v);
  }
  void integer(Key key, long long v, long long min, long long max) {
    add(key, std::to_string(min) + ".." + std::to_string(max), v);
  }
  void integer_of(Key key, long long v, std::span<const int> set, std::string_view) {
    add(key, join(set, [](int i) { return std::to_string(i); }), v);
  }
  void boolean(Key key, bool v) { add(key, "true, false", v); }
  void text(Key key, std::string_view v, std::string_view allowed, Text) {
    add(key, std::string(allowed), v);
  }
  template <typename T, typename U, std::size_t N>
  void choice(Key key, const T& v, const Word<U> (&words)[N], Presence = Presence::kOptional) {
    add(key, join(words, [](const auto& w) { return w.word; }), word_of(words, v, words[0].word));
  }
  void range(Key key, double lo, double hi, double min, double max, std::string_view unit) {
    add(key, "[min, max] within " + limits_text(min, max, unit), lo, hi);
  }
  void vector3(Key key, const core::Vec3& v, double min, double max, std::string_view unit) {
    add(key, "3 numbers within " + limits_text(min, max, unit), v);
  }
  void transform(Key key, const Eigen::Matrix4d& m) {
    add(key, "rigid 4x4 transform, translation in m", m);
  }
  template <typename T, typename Fn>
  void list(Key key, const std::vector<T>& items, std::string_view allowed, Fn&& each) {
    YAML::Emitter out;
    out << YAML::Flow;
    Writer(out).items_of(items, each);
    keys.push_back(
        {prefix_ + std::string(key), out.c_str(), std::string(allowed), std::string(key.meaning)});
  }

 private:
  template <typename... V>
  void add(Key key, std::string allowed, const V&... v) {
    YAML::Emitter out;
    out.SetDoublePrecision(kDoublePrecision);
    out << YAML::Flow;
    put(out, v...);
    keys.push_back(
        {prefix_ + std::string(key), out.c_str(), std::move(allowed), std::string(key.meaning)});
  }

  std::string prefix_;
};

}  // namespace

std::string to_yaml(const Config& config) {
  YAML::Emitter out;
  out.SetDoublePrecision(kDoublePrecision);
  out << YAML::BeginMap;
  Writer writer(out);
  fields(writer, config);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::vector<ConfigKey> config_keys(const Config& config) {
  KeyList list;
  fields(list, config);
  return std::move(list.keys);
}

std::vector<std::string> changed_keys(const Config& before, const Config& after) {
  const auto a = config_keys(before);
  const auto b = config_keys(after);  // the same keys in the same order
  std::vector<std::string> out;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].value != b[i].value) out.push_back(a[i].path);
  }
  return out;
}

}  // namespace ajar::daemon
