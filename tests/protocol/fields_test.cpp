// visit_fields() (fields.hpp), the walk behind the JSON of ajarctl and the console: every field of
// every message, under the names of the layout tables, in wire order, with the values on the wire.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/fields.hpp"
#include "ajar/protocol/layout.hpp"
#include "ajar/protocol/vectors.hpp"
#include "samples.hpp"

namespace ajar::protocol {
namespace {

struct Recorded {
  std::string name;
  FieldValue value;
};
struct Recorder final : FieldVisitor {
  std::vector<Recorded> fields;
  void field(std::string_view name, const FieldValue& value) override {
    fields.push_back({std::string(name), value});
  }
};

std::vector<std::string> layout_names(const Message& m, std::uint8_t minor) {
  std::vector<std::string> names;
  for (const FieldLayout& f : payload_layout(m, minor))
    names.emplace_back(f.name);
  return names;
}

// Every message type and Ack body, in every minor that has it: the visited names are the layout's
// (docs/protocol.md's tables are tested against the layout), in its order; a minor without the
// type visits nothing.
TEST(Fields, EveryMessageVisitsItsLayoutInEveryMinor) {
  std::size_t checked = 0;
  for (const auto& sample : samples::all()) {
    const Message& m = sample.envelope.message;
    for (std::uint8_t minor = 0; minor <= kVersionMinor; ++minor) {
      Recorder r;
      const bool walked = visit_fields(m, r, minor);
      const auto layout = layout_names(m, minor);
      std::vector<std::string> visited;
      for (const auto& f : r.fields)
        visited.push_back(f.name);
      std::uint8_t needs = minor_of(type_of(m));
      if (const auto* ack = std::get_if<Ack>(&m))
        needs = std::max(needs, minor_of(ack->acknowledged));
      if (minor < needs) {
        EXPECT_FALSE(walked) << sample.name << " 1." << int{minor};
        EXPECT_TRUE(layout.empty()) << sample.name << " 1." << int{minor};
        continue;
      }
      EXPECT_TRUE(walked) << sample.name << " 1." << int{minor};
      EXPECT_EQ(visited, layout) << sample.name << " 1." << int{minor};
      ++checked;
    }
  }
  EXPECT_GE(checked, std::variant_size_v<Message>);
}

std::uint64_t little_endian(const std::uint8_t* p, std::size_t size) {
  std::uint64_t v = 0;
  for (std::size_t i = size; i-- > 0;)
    v = (v << 8) | p[i];
  return v;
}

// What the value says the bytes at its offset are; empty when they match.
std::string differs(const FieldValue& value, const FieldLayout& f, const std::uint8_t* at) {
  const std::uint64_t raw = f.size <= 8 ? little_endian(at, f.size) : 0;
  const auto bad = [](const std::string& got) { return "visited " + got; };
  if (const auto* b = std::get_if<bool>(&value)) {
    return raw == (*b ? 1u : 0u) && f.type == "bool" ? "" : bad(std::to_string(*b));
  }
  if (const auto* i = std::get_if<std::int64_t>(&value)) {
    const auto shift = 64 - 8 * f.size;
    const auto wire = static_cast<std::int64_t>(raw << shift) >> shift;
    return wire == *i && f.type.starts_with("i") ? "" : bad(std::to_string(*i));
  }
  if (const auto* u = std::get_if<std::uint64_t>(&value)) {
    return raw == *u && f.type.starts_with("u") ? "" : bad(std::to_string(*u));
  }
  if (const auto* x = std::get_if<float>(&value)) {
    return raw == std::bit_cast<std::uint32_t>(*x) && f.type == "f32" ? ""
                                                                      : bad(std::to_string(*x));
  }
  if (const auto* x = std::get_if<double>(&value)) {
    return raw == std::bit_cast<std::uint64_t>(*x) && f.type == "f64" ? ""
                                                                      : bad(std::to_string(*x));
  }
  if (const auto* w = std::get_if<FieldWord>(&value)) {
    const bool known = !w->word.empty() && w->word != "unknown" && w->word != "Unknown";
    return raw == w->raw && known ? "" : bad(std::string(w->word));
  }
  if (const auto* t = std::get_if<FieldText>(&value)) {
    const std::string_view wire(reinterpret_cast<const char*>(at + 1), at[0]);
    return wire == t->text && f.type.starts_with("str<") ? "" : bad(std::string(t->text));
  }
  const auto& bytes = std::get<std::span<const std::uint8_t>>(value);
  const std::size_t n = little_endian(at, 2);
  return n == bytes.size() && std::memcmp(at + 2, bytes.data(), n) == 0 ? ""
                                                                        : bad(std::string("bytes"));
}

// Every valid golden vector decoded and visited: each value is the bytes at its field's offset
// (numbers bit for bit, enums their raw value with a known word, text and bytes as sent).
TEST(Fields, EveryGoldenVectorVisitsTheValuesOnTheWire) {
  std::size_t vectors = 0, fields = 0;
  for (const auto& entry : std::filesystem::directory_iterator(AJAR_VECTOR_DIR)) {
    if (entry.path().extension() != ".vec") continue;
    std::ifstream file(entry.path(), std::ios::binary);
    std::stringstream text;
    text << file.rdbuf();
    const auto v = parse_vector(text.str());
    ASSERT_TRUE(v.ok()) << entry.path();
    if (!v->expect_ok) continue;
    const auto decoded = decode_frame(v->bytes);
    ASSERT_EQ(decoded.kind, StreamDecoder::Kind::kMessage) << v->name;
    // A newer minor's frame is read in this version's layout (its appended tail ignored).
    const std::uint8_t minor = std::min(
        decode_header(std::span<const std::uint8_t, kHeaderSize>(v->bytes.data(), kHeaderSize))
            .version_minor,
        kVersionMinor);
    const Message& m = decoded.envelope.message;
    const auto layout = payload_layout(m, minor);
    Recorder r;
    EXPECT_TRUE(visit_fields(m, r, minor)) << v->name;
    ASSERT_EQ(r.fields.size(), layout.size()) << v->name;
    for (std::size_t i = 0; i < layout.size(); ++i) {
      EXPECT_EQ(r.fields[i].name, layout[i].name) << v->name;
      const std::uint8_t* at = v->bytes.data() + kHeaderSize + layout[i].offset;
      EXPECT_EQ(differs(r.fields[i].value, layout[i], at), "")
          << v->name << ": " << layout[i].name << " (" << layout[i].type << ")";
      ++fields;
    }
    ++vectors;
  }
  EXPECT_GE(vectors, std::variant_size_v<Message>);
  EXPECT_GE(fields, 500u);
}

// An Ack's body alone: the names the Ack gives it, no prefix.
TEST(Fields, AnAckBodyIsVisitedAsTheAckCarriesIt) {
  Ack ack;
  ack.acknowledged = MessageType::kMeasureDoorPlane;
  ack.body = samples::plane_ack();
  Recorder whole, body;
  ASSERT_TRUE(visit_fields(Message(ack), whole));
  visit_fields(ack.body, body);
  ASSERT_EQ(whole.fields.size(), body.fields.size() + 2);  // acknowledged, state
  for (std::size_t i = 0; i < body.fields.size(); ++i)
    EXPECT_EQ(body.fields[i].name, whole.fields[i + 2].name);
  EXPECT_EQ(std::get<FieldWord>(whole.fields[0].value).word, "MeasureDoorPlane");
  Recorder none;
  visit_fields(AckBody{EmptyAck{}}, none);
  EXPECT_TRUE(none.fields.empty());
}

}  // namespace
}  // namespace ajar::protocol
