// The payload layout of a message, listed from the same message tables the codec encodes and
// decodes with: for tools, the golden vector generator (offsets of the fields it corrupts) and the
// test that keeps the layout tables of docs/protocol.md true. Not for the realtime path
// (allocates).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "ajar/protocol/messages.hpp"

namespace ajar::protocol {

struct FieldLayout {
  std::size_t offset = 0;  // bytes from the start of the payload
  std::size_t size = 0;    // bytes on the wire
  std::string_view type;   // u8 u16 u32 u64 i8 i64 f32 f64 bool str<N> (enums: u8; ErrorCode,
                           // MessageType: u16)
  std::string_view name;   // as DecodeError::field names it: "width.p1_base_m.x", "points[2].z"
  std::uint8_t since = 0;  // the minor version that appended the field (0: in the 1.0 layout)
};

// The fields of `m`'s payload in protocol 1.`minor`, in wire order. The layout depends on the
// value only where the protocol says so: a MeasureDoorPlane has `count` points, an Ack the body
// of its `acknowledged` type. Empty when encode() would refuse `m` in that minor (a type or Ack
// the minor does not have, a body that does not match, a count outside 3..16).
std::vector<FieldLayout> payload_layout(const Message& m, std::uint8_t minor = kVersionMinor);

// The offset of the field `name` in `m`'s payload (protocol 1.`minor`); -1 when it has none.
std::ptrdiff_t offset_of(const Message& m, std::string_view name,
                         std::uint8_t minor = kVersionMinor);

}  // namespace ajar::protocol
