#include "ajar/client/json.hpp"

#include <charconv>
#include <cmath>
#include <cstdlib>

#include <nlohmann/json.hpp>

#include "ajar/protocol/fields.hpp"

namespace ajar::client {
namespace {

using Json = nlohmann::ordered_json;

Json number(double value) {
  return std::isfinite(value) ? Json(value) : Json(nullptr);
}

Json vec3(const core::Vec3& v) {
  return Json::array({number(v.x()), number(v.y()), number(v.z())});
}

std::string dump(const Json& json) {
  return json.dump(-1, ' ', false, Json::error_handler_t::replace);
}

// An f32 as the double of its shortest decimal text (0.6f: 0.6, not 0.6000000238418579), which
// reads back to the same float.
Json number(float value) {
  if (!std::isfinite(value)) return nullptr;
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text - 1, value).ptr;
  *end = '\0';
  return std::strtod(text, nullptr);
}

std::string base64(std::span<const std::uint8_t> bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t v = std::uint32_t{bytes[i]} << 16;
    if (n > 1) v |= std::uint32_t{bytes[i + 1]} << 8;
    if (n > 2) v |= bytes[i + 2];
    for (std::size_t k = 0; k < 4; ++k)
      out += k <= n ? kAlphabet[(v >> (18 - 6 * k)) & 0x3F] : '=';
  }
  return out;
}

// Puts each visited field at the place its wire name says: "a.b" is key b of object a, "a[2]"
// element 2 of array a.
class FieldsToJson final : public protocol::FieldVisitor {
 public:
  Json root = Json::object();

  void field(std::string_view name, const protocol::FieldValue& value) override {
    Json* at = &root;
    std::size_t i = 0;
    while (i < name.size()) {
      if (name[i] == '[') {
        const std::size_t close = name.find(']', i);
        std::size_t index = 0;
        std::from_chars(name.data() + i + 1, name.data() + close, index);
        at = &(*at)[index];
        i = close + 1;
      } else {
        if (name[i] == '.') ++i;
        const std::size_t end = std::min(name.find_first_of(".[", i), name.size());
        at = &(*at)[std::string(name.substr(i, end - i))];
        i = end;
      }
    }
    *at = std::visit([](const auto& v) { return json_of(v); }, value);
  }

 private:
  static Json json_of(bool v) { return v; }
  static Json json_of(std::int64_t v) { return v; }
  static Json json_of(std::uint64_t v) { return v; }
  static Json json_of(float v) { return number(v); }
  static Json json_of(double v) { return number(v); }
  static Json json_of(const protocol::FieldWord& w) {
    if (w.word.empty()) return w.raw;  // a code or type this version has no word for
    return std::string(w.word);
  }
  static Json json_of(const protocol::FieldText& t) { return std::string(t.text); }
  static Json json_of(std::span<const std::uint8_t> b) { return base64(b); }
};

}  // namespace

struct JsonObject::Value {
  Json json = Json::object();
};
struct JsonArray::Value {
  Json json = Json::array();
};

std::string json_number(double value) {
  return dump(number(value));
}
std::string json_vec3(const core::Vec3& v) {
  return dump(vec3(v));
}
JsonObject::JsonObject() = default;
JsonObject::~JsonObject() = default;
JsonObject::JsonObject(const JsonObject& other)
    : value_(other.value_ ? std::make_unique<Value>(*other.value_) : nullptr) {}
JsonObject::JsonObject(JsonObject&& other) noexcept = default;
JsonObject& JsonObject::operator=(const JsonObject& other) {
  if (this != &other) value_ = other.value_ ? std::make_unique<Value>(*other.value_) : nullptr;
  return *this;
}
JsonObject& JsonObject::operator=(JsonObject&& other) noexcept = default;

JsonObject::Value& JsonObject::value() {
  if (!value_) value_ = std::make_unique<Value>();
  return *value_;
}

JsonObject& JsonObject::add(std::string_view key, std::string_view text) {
  value().json[std::string(key)] = std::string(text);
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, double v) {
  value().json[std::string(key)] = number(v);
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, std::int64_t v) {
  value().json[std::string(key)] = v;
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, std::uint64_t v) {
  value().json[std::string(key)] = v;
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, bool v) {
  value().json[std::string(key)] = v;
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, const core::Vec3& v) {
  value().json[std::string(key)] = vec3(v);
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, const JsonObject& nested) {
  value().json[std::string(key)] = nested.value_ ? nested.value_->json : Json::object();
  return *this;
}
JsonObject& JsonObject::add(std::string_view key, const JsonArray& array) {
  value().json[std::string(key)] = array.value_ ? array.value_->json : Json::array();
  return *this;
}
JsonObject& JsonObject::add_null(std::string_view key) {
  value().json[std::string(key)] = nullptr;
  return *this;
}
JsonObject& JsonObject::merge(const JsonObject& other) {
  if (other.value_) {
    for (const auto& [key, v] : other.value_->json.items())
      value().json[key] = v;
  }
  return *this;
}
JsonObject JsonObject::member(std::string_view key) const {
  JsonObject out;
  if (!value_) return out;
  const auto it = value_->json.find(std::string(key));
  if (it != value_->json.end() && it->is_object()) out.value().json = *it;
  return out;
}
std::string JsonObject::str() const {
  return value_ ? dump(value_->json) : "{}";
}
bool JsonObject::empty() const {
  return !value_ || value_->json.empty();
}

JsonArray::JsonArray() = default;
JsonArray::~JsonArray() = default;
JsonArray::JsonArray(const JsonArray& other)
    : value_(other.value_ ? std::make_unique<Value>(*other.value_) : nullptr) {}
JsonArray::JsonArray(JsonArray&& other) noexcept = default;
JsonArray& JsonArray::operator=(const JsonArray& other) {
  if (this != &other) value_ = other.value_ ? std::make_unique<Value>(*other.value_) : nullptr;
  return *this;
}
JsonArray& JsonArray::operator=(JsonArray&& other) noexcept = default;

JsonArray::Value& JsonArray::value() {
  if (!value_) value_ = std::make_unique<Value>();
  return *value_;
}

JsonArray& JsonArray::add(std::string_view text) {
  value().json.push_back(std::string(text));
  return *this;
}
JsonArray& JsonArray::add(double v) {
  value().json.push_back(number(v));
  return *this;
}
JsonArray& JsonArray::add(std::int64_t v) {
  value().json.push_back(v);
  return *this;
}
JsonArray& JsonArray::add(const JsonObject& object) {
  value().json.push_back(object.value_ ? object.value_->json : Json::object());
  return *this;
}
JsonArray& JsonArray::add(const JsonArray& array) {
  value().json.push_back(array.value_ ? array.value_->json : Json::array());
  return *this;
}

std::string JsonArray::str() const {
  return value_ ? dump(value_->json) : "[]";
}
std::size_t JsonArray::size() const {
  return value_ ? value_->json.size() : 0;
}

struct JsonAccess {
  static JsonObject object(Json json) {
    JsonObject out;
    out.value().json = std::move(json);
    return out;
  }
};

JsonObject message_json(const protocol::Message& message, std::uint8_t minor) {
  // No message comes in a minor older than the one that defined it (or its Ack's type).
  minor = std::max(minor, protocol::minor_of(protocol::type_of(message)));
  if (const auto* ack = std::get_if<protocol::Ack>(&message))
    minor = std::max(minor, protocol::minor_of(ack->acknowledged));
  FieldsToJson fields;
  protocol::visit_fields(message, fields, minor);
  return JsonAccess::object(std::move(fields.root));
}

JsonObject ack_body_json(const protocol::AckBody& body) {
  FieldsToJson fields;
  protocol::visit_fields(body, fields);
  return JsonAccess::object(std::move(fields.root));
}

}  // namespace ajar::client
