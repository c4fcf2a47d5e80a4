// Every wire field of a message, by its wire name and value, walked along the message tables the
// codec encodes and decodes with (protocol/src/message_schema.hpp). The one walk behind the JSON of
// ajarctl --json and of the console (client/src/json.cpp, docs/protocol.md section 10) and
// the RobotModel printers: a field added to a Schema appears in all of them, under the name the
// layout tables and DecodeError give it. Not for the realtime path (the caller's visitor may
// allocate; the walk itself does not).
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <variant>

#include "ajar/protocol/messages.hpp"

namespace ajar::protocol {

// An enum as its word: a protocol enum's EnumWords row ("awaiting_width"), core's Frame and
// RotationDirection ("camera", "CCW"), an ErrorCode's NAME ("POINTS_COLLINEAR"), a MessageType's
// message name ("MeasureDoorWidth"); `raw` is the value on the wire. `word` is empty for a value
// this version has no word for (an ErrorCode or MessageType of a newer peer).
struct FieldWord {
  std::string_view word;
  std::uint16_t raw = 0;
};
// A str<N> field's text (the bytes as sent: not checked to be UTF-8).
struct FieldText {
  std::string_view text;
};
// A scalar by its wire type: bool; i8/i64 as int64; u8..u64 as uint64; f32 as float; f64 as
// double; an enum as its word; str<N> as text; bytes<N> as the bytes.
using FieldValue = std::variant<bool, std::int64_t, std::uint64_t, float, double, FieldWord,
                                FieldText, std::span<const std::uint8_t>>;

class FieldVisitor {
 public:
  // One scalar, in wire order. `name` as the layout tables of docs/protocol.md and DecodeError name
  // it: a nested block's fields after a '.', an array element as [i] ("timing.all.latency.p99_ns",
  // "points[2].x", "camera_to_base[11]"; an Ack's body fields without a prefix: "length_m").
  virtual void field(std::string_view name, const FieldValue& value) = 0;

 protected:
  FieldVisitor() = default;
  FieldVisitor(const FieldVisitor&) = default;
  FieldVisitor& operator=(const FieldVisitor&) = default;
  ~FieldVisitor() = default;
};

// Visits every field of `m` in protocol 1.`minor`, in wire order: the fields a later minor appended
// are left out, exactly as encode() in that minor leaves them out. False where encode() would
// refuse `m` (a type the minor does not have, a count outside 3..16, an Ack whose body does not
// match its type): the fields before that point were visited.
bool visit_fields(const Message& m, FieldVisitor& visitor, std::uint8_t minor = kVersionMinor);

// The fields of an Ack body as the Ack carries them (no prefix: "length_m", "normal.x"); none for
// EmptyAck.
void visit_fields(const AckBody& body, FieldVisitor& visitor);

}  // namespace ajar::protocol
