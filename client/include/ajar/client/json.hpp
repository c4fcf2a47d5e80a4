// Hand-written JSON output for ajarctl --json: one object per line. Strings are escaped (quotes,
// backslash, control characters as \u00XX; other bytes pass through), numbers are written with 17
// significant digits (round-trip exact); NaN and infinity become null. Field names are documented
// in docs/ajarctl.md.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "ajar/core/types.hpp"

namespace ajar::client {

std::string json_escape(std::string_view text);  // without the surrounding quotes
std::string json_string(std::string_view text);  // with the quotes
std::string json_number(double value);           // shortest of %.17g; non-finite -> null
std::string json_vec3(const core::Vec3& v);      // [x, y, z]

// Builds one JSON object, field by field, in insertion order.
class JsonObject {
 public:
  JsonObject& add(std::string_view key, std::string_view text);
  JsonObject& add(std::string_view key, const char* text) {
    return add(key, std::string_view(text));
  }
  JsonObject& add(std::string_view key, double value);
  JsonObject& add(std::string_view key, float value) {
    return add(key, static_cast<double>(value));
  }
  JsonObject& add(std::string_view key, std::int64_t value);
  JsonObject& add(std::string_view key, std::uint64_t value);
  JsonObject& add(std::string_view key, int value) {
    return add(key, static_cast<std::int64_t>(value));
  }
  JsonObject& add(std::string_view key, unsigned value) {
    return add(key, static_cast<std::uint64_t>(value));
  }
  JsonObject& add(std::string_view key, bool value);
  JsonObject& add(std::string_view key, const core::Vec3& value);
  JsonObject& add_raw(std::string_view key, std::string_view json);  // value is already JSON
  JsonObject& add(std::string_view key, const JsonObject& nested) {
    return add_raw(key, nested.str());
  }
  std::string str() const { return body_.empty() ? "{}" : "{" + body_ + "}"; }
  bool empty() const { return body_.empty(); }

 private:
  void key(std::string_view k);
  std::string body_;
};

}  // namespace ajar::client
