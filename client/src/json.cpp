#include "ajar/client/json.hpp"

#include <cmath>

#include <nlohmann/json.hpp>

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

}  // namespace ajar::client
