// JSON output for ajarctl --json and the console: one compact object per line. nlohmann-json
// (private to ajar_client: this header does not include it) holds the values and writes them:
// strings escaped as JSON requires (bytes that are not UTF-8 become U+FFFD), integers exact,
// floating-point numbers as the shortest text that reads back to the same double, NaN and infinity
// as null. Objects keep their keys in insertion order. Field names are documented in
// docs/ajarctl.md.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "ajar/core/types.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::client {

std::string json_number(double value);       // e.g. "0.9152", "1.0"; non-finite -> "null"
std::string json_vec3(const core::Vec3& v);  // [x,y,z]

class JsonArray;

// Builds one JSON object, field by field, in insertion order (a key added twice keeps its first
// place and its last value). A moved-from object is empty.
class JsonObject {
 public:
  JsonObject();
  ~JsonObject();
  JsonObject(const JsonObject& other);
  JsonObject(JsonObject&& other) noexcept;
  JsonObject& operator=(const JsonObject& other);
  JsonObject& operator=(JsonObject&& other) noexcept;

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
  JsonObject& add(std::string_view key, const core::Vec3& value);  // [x, y, z]
  JsonObject& add(std::string_view key, const JsonObject& nested);
  JsonObject& add(std::string_view key, const JsonArray& array);
  JsonObject& add_null(std::string_view key);
  // Adds every key of `other`, in its order (as add() would, one by one).
  JsonObject& merge(const JsonObject& other);
  // The object under `key`; empty when there is none (or it is not an object).
  JsonObject member(std::string_view key) const;

  std::string str() const;  // one line, no spaces: {"type":"ack","ok":true}
  bool empty() const;

 private:
  friend class JsonArray;
  friend struct JsonAccess;  // json.cpp: message_json()
  struct Value;
  Value& value();
  std::unique_ptr<Value> value_;
};

// Builds one JSON array, element by element. A moved-from array is empty.
class JsonArray {
 public:
  JsonArray();
  ~JsonArray();
  JsonArray(const JsonArray& other);
  JsonArray(JsonArray&& other) noexcept;
  JsonArray& operator=(const JsonArray& other);
  JsonArray& operator=(JsonArray&& other) noexcept;

  JsonArray& add(std::string_view text);
  JsonArray& add(const char* text) { return add(std::string_view(text)); }
  JsonArray& add(double value);
  JsonArray& add(std::int64_t value);
  JsonArray& add(int value) { return add(static_cast<std::int64_t>(value)); }
  JsonArray& add(const JsonObject& object);
  JsonArray& add(const JsonArray& array);

  std::string str() const;  // [1.5,"a",{"b":true}]
  std::size_t size() const;

 private:
  friend class JsonObject;
  struct Value;
  Value& value();
  std::unique_ptr<Value> value_;
};

// A protocol message as JSON, the one shape of ajarctl --json and the console (docs/protocol.md
// section 10), generated from the message tables (protocol::visit_fields): every wire field of
// protocol 1.`minor`, in wire order, under its wire name, where a '.' in the name opens a nested
// object and [i] is an array element ("timing.all.latency.p99_ns", "normal.x", "points[2].frame",
// "camera_to_base[11]"); enums as their words, ErrorCode as its NAME, MessageType as the message
// name (a code or type this version does not know: its number); numbers as numbers (f32 as the
// shortest text that reads back to the same float, NaN and infinity as null); str<N> as strings;
// bytes<N> as base64 (RFC 4648). An Ack's body fields sit next to acknowledged and state, as on the
// wire. Fields a later minor appended are left out
// (`minor` is at least the one that defined the message's type).
JsonObject message_json(const protocol::Message& message,
                        std::uint8_t minor = protocol::kVersionMinor);
// An Ack body alone, as message_json() puts it in its Ack.
JsonObject ack_body_json(const protocol::AckBody& body);

}  // namespace ajar::client
