// The JSON of a message (client::message_json, docs/protocol.md section 10), generated from the
// message tables: for every message type and every golden vector, its keys are the layout's
// field names (a '.' nests an object, [i] an array element), in wire order, and its values the
// values on the wire. ajarctl's printers put exactly that JSON in their lines; the RobotModel
// printers show every field. (The console prints the same JSON:
// tests/console/daemon_json_test.cpp.)
#include <gtest/gtest.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../protocol/samples.hpp"
#include "ajar/client/json.hpp"
#include "ajar/client/output.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/layout.hpp"
#include "ajar/protocol/vectors.hpp"

namespace ajar::client {
namespace {

using OrderedJson = nlohmann::ordered_json;
using protocol::FieldLayout;

OrderedJson parse_ordered(const JsonObject& o) {
  return OrderedJson::parse(o.str());
}

// Every leaf of `j` with its path: "a.b" for key b of object a, "a[2]" for element 2 of array a.
void flatten(const OrderedJson& j, const std::string& path,
             std::vector<std::pair<std::string, OrderedJson>>& out) {
  if (j.is_object()) {
    for (const auto& [key, v] : j.items())
      flatten(v, path.empty() ? key : path + "." + key, out);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i)
      flatten(j[i], path + "[" + std::to_string(i) + "]", out);
  } else {
    out.emplace_back(path, j);
  }
}
std::vector<std::pair<std::string, OrderedJson>> leaves(const JsonObject& o) {
  std::vector<std::pair<std::string, OrderedJson>> out;
  flatten(parse_ordered(o), "", out);
  return out;
}

std::vector<std::string> names(const std::vector<FieldLayout>& layout) {
  std::vector<std::string> out;
  for (const auto& f : layout)
    out.emplace_back(f.name);
  return out;
}

std::uint8_t oldest_minor(const protocol::Message& m) {
  std::uint8_t minor = protocol::minor_of(protocol::type_of(m));
  if (const auto* ack = std::get_if<protocol::Ack>(&m))
    minor = std::max(minor, protocol::minor_of(ack->acknowledged));
  return minor;
}

// Every message type and Ack body, in every minor that has it.
TEST(MessageJson, TheKeysOfEveryMessageAreItsLayoutsNamesInWireOrder) {
  std::size_t checked = 0;
  for (const auto& sample : protocol::samples::all()) {
    const protocol::Message& m = sample.envelope.message;
    for (std::uint8_t minor = oldest_minor(m); minor <= protocol::kVersionMinor; ++minor) {
      std::vector<std::string> keys;
      for (const auto& [path, value] : leaves(message_json(m, minor)))
        keys.push_back(path);
      EXPECT_EQ(keys, names(protocol::payload_layout(m, minor)))
          << sample.name << " 1." << int{minor} << ": " << message_json(m, minor).str();
      ++checked;
    }
  }
  EXPECT_GE(checked, std::variant_size_v<protocol::Message>);
}

std::uint64_t little_endian(const std::uint8_t* p, std::size_t size) {
  std::uint64_t v = 0;
  for (std::size_t i = size; i-- > 0;)
    v = (v << 8) | p[i];
  return v;
}

std::string base64(const std::uint8_t* p, std::size_t n) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < n; i += 3) {
    const std::uint32_t v = (std::uint32_t{p[i]} << 16) |
                            (i + 1 < n ? std::uint32_t{p[i + 1]} << 8 : 0) |
                            (i + 2 < n ? std::uint32_t{p[i + 2]} : 0);
    for (std::size_t k = 0; k < 4; ++k)
      out += k <= n - i ? kAlphabet[(v >> (18 - 6 * k)) & 0x3F] : '=';
  }
  return out;
}

// Whether the JSON value `j` is what the field's bytes at `at` say; the words of enums are checked
// by kind (a non-empty known word), their values by the golden vectors' decode.
std::string differs(const OrderedJson& j, const FieldLayout& f, const std::uint8_t* at) {
  const std::string type(f.type);
  const std::uint64_t raw = f.size <= 8 ? little_endian(at, f.size) : 0;
  const auto bad = [&] { return "json " + j.dump() + " for " + type; };
  if (type == "bool") return j.is_boolean() && j.get<bool>() == (raw == 1) ? "" : bad();
  if (type == "f64") {
    const double wire = std::bit_cast<double>(raw);
    if (!std::isfinite(wire)) return j.is_null() ? "" : bad();
    return j.is_number() && std::bit_cast<std::uint64_t>(j.get<double>()) == raw ? "" : bad();
  }
  if (type == "f32") {
    const float wire = std::bit_cast<float>(static_cast<std::uint32_t>(raw));
    if (!std::isfinite(wire)) return j.is_null() ? "" : bad();
    // The shortest text that reads back to the same float (0.6f: 0.6).
    char shortest[32] = {};
    std::to_chars(shortest, shortest + sizeof shortest - 1, wire);
    return j.is_number() && j.get<double>() == std::strtod(shortest, nullptr) ? "" : bad();
  }
  if (type.starts_with("str<")) {
    const std::string wire(reinterpret_cast<const char*>(at + 1), at[0]);
    return j.is_string() && j.get<std::string>() == wire ? "" : bad();
  }
  if (type.starts_with("bytes<")) {
    const std::size_t n = little_endian(at, 2);
    return j.is_string() && j.get<std::string>() == base64(at + 2, n) ? "" : bad();
  }
  if (j.is_string()) {  // an enum: u8, or u16 (ErrorCode, MessageType)
    const std::string word = j.get<std::string>();
    return (type == "u8" || type == "u16") && !word.empty() && word != "unknown" &&
                   word != "Unknown"
               ? ""
               : bad();
  }
  if (type.starts_with("i")) {
    const auto shift = 64 - 8 * f.size;
    const auto wire = static_cast<std::int64_t>(raw << shift) >> shift;
    return j.is_number_integer() && j.get<std::int64_t>() == wire ? "" : bad();
  }
  return j.is_number_integer() && j.get<std::uint64_t>() == raw ? "" : bad();
}

// Bytes -> decode -> JSON: every leaf is the value on the wire at its field's offset (numbers bit
// for bit, f32 as the shortest text of the float, text and bytes as sent), for every golden vector.
TEST(MessageJson, EveryGoldenVectorsJsonHoldsTheValuesOnTheWire) {
  std::size_t vectors = 0, fields = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(AJAR_SOURCE_DIR "/tests/conformance/vectors")) {
    if (entry.path().extension() != ".vec") continue;
    std::ifstream file(entry.path(), std::ios::binary);
    std::stringstream text;
    text << file.rdbuf();
    const auto v = protocol::parse_vector(text.str());
    ASSERT_TRUE(v.ok()) << entry.path();
    if (!v->expect_ok) continue;
    const auto decoded = protocol::decode_frame(v->bytes);
    ASSERT_EQ(decoded.kind, protocol::StreamDecoder::Kind::kMessage) << v->name;
    // A newer minor's frame is read in this version's layout (its appended tail ignored).
    const std::uint8_t minor =
        std::min(v->bytes[protocol::kOffsetVersionMinor], protocol::kVersionMinor);
    const protocol::Message& m = decoded.envelope.message;
    const auto layout = protocol::payload_layout(m, minor);
    const auto json = leaves(message_json(m, minor));
    ASSERT_EQ(json.size(), layout.size()) << v->name << ": " << message_json(m, minor).str();
    for (std::size_t i = 0; i < layout.size(); ++i) {
      EXPECT_EQ(json[i].first, layout[i].name) << v->name;
      const std::uint8_t* at = v->bytes.data() + protocol::kHeaderSize + layout[i].offset;
      EXPECT_EQ(differs(json[i].second, layout[i], at), "") << v->name << ": " << layout[i].name;
      ++fields;
    }
    ++vectors;
  }
  EXPECT_GE(vectors, std::variant_size_v<protocol::Message>);
  EXPECT_GE(fields, 500u);
}

Response reply(protocol::Message m, std::uint8_t minor = protocol::kVersionMinor) {
  Response r;
  r.outcome = CallOutcome::kReply;
  r.request_id = 9;
  r.session_minor = minor;
  r.reply = std::move(m);
  return r;
}

// ajarctl's lines carry the message's JSON unchanged: an Ack's and a Pong's fields after type,
// command, ok, request_id; Status, RobotModel, Welcome as one object; events and telemetry after
// type; a refusal's Error as "error" (plus its code's number).
TEST(MessageJson, AjarctlsLinesCarryTheMessagesJsonUnchanged) {
  for (const auto& sample : protocol::samples::all()) {
    const protocol::Message& m = sample.envelope.message;
    const OrderedJson generated = parse_ordered(message_json(m));
    OrderedJson line;
    std::set<std::string> own;
    if (std::holds_alternative<protocol::Ack>(m)) {
      line = parse_ordered(response_object("x", reply(m)));
      own = {"type", "command", "ok", "request_id"};
    } else if (std::holds_alternative<protocol::Pong>(m)) {
      line = parse_ordered(response_object("ping", reply(m)));
      own = {"type", "command", "ok"};
    } else if (std::holds_alternative<protocol::Status>(m)) {
      line = parse_ordered(response_object("status", reply(m))).at("status");
    } else if (std::holds_alternative<protocol::RobotModel>(m)) {
      line = parse_ordered(response_object("model", reply(m))).at("robot_model");
    } else if (std::holds_alternative<protocol::Welcome>(m)) {
      line = parse_ordered(response_object("hello", reply(m))).at("welcome");
    } else if (const auto* e = std::get_if<protocol::Event>(&m)) {
      line = parse_ordered(event_object(*e));
      own = {"type"};
    } else if (const auto* t = std::get_if<protocol::Telemetry>(&m)) {
      line = parse_ordered(telemetry_object(*t));
      own = {"type"};
    } else if (const auto* error = std::get_if<protocol::ErrorReply>(&m)) {
      Response refused;
      refused.outcome = CallOutcome::kRefused;
      refused.error = *error;
      line = parse_ordered(response_object("x", refused)).at("error");
      own = {"number"};
    } else {
      continue;
    }
    for (const auto& key : own) {
      EXPECT_TRUE(line.contains(key)) << sample.name << ": " << key;
      line.erase(key);
    }
    EXPECT_EQ(line, generated) << sample.name;
  }
}

// A newer peer's code or type, which this version has no word for, is its number (not "UNKNOWN").
TEST(MessageJson, AnUnknownCodeOrTypeIsItsNumber) {
  protocol::ErrorReply e;
  e.code = static_cast<ErrorCode>(999);
  e.offending_type = static_cast<protocol::MessageType>(0x0199);
  e.field = "header.type";
  const OrderedJson j = parse_ordered(message_json(e));
  EXPECT_EQ(j.at("code"), 999);
  EXPECT_EQ(j.at("offending_type"), 0x0199);
  e.code = ErrorCode::kUnknownMessageType;
  EXPECT_EQ(parse_ordered(message_json(e)).at("code"), "UNKNOWN_MESSAGE_TYPE");
}

// RobotModel: the JSON and the text name every one of its fields (its layout's top-level names).
TEST(MessageJson, TheRobotModelPrintersShowEveryField) {
  const protocol::RobotModel model = protocol::samples::robot_model();
  std::vector<std::string> fields;
  for (const auto& f : protocol::payload_layout(model)) {
    const std::string name(f.name.substr(0, f.name.find_first_of(".[")));
    if (fields.empty() || fields.back() != name) fields.push_back(name);
  }
  EXPECT_EQ(fields.size(), 37u);
  std::vector<std::string> keys;
  const OrderedJson json = parse_ordered(robot_model_object(model));
  for (const auto& [key, value] : json.items())
    keys.push_back(key);
  EXPECT_EQ(keys, fields);
  std::vector<std::string> lines;
  std::istringstream text(robot_model_text(model));
  for (std::string line; std::getline(text, line);)
    lines.push_back(line.substr(0, line.find(':')));
  EXPECT_EQ(lines, fields) << robot_model_text(model);
  EXPECT_NE(
      robot_model_text(model).find("right:                          card_axis 2  polarity -1"),
      std::string::npos)
      << robot_model_text(model);
}

}  // namespace
}  // namespace ajar::client
