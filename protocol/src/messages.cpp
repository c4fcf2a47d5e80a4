#include "ajar/protocol/messages.hpp"

#include "ajar/protocol/message_table.hpp"

#include "message_schema.hpp"

namespace ajar::protocol {

namespace {

// Length of the UTF-8 sequence starting at s[i] when it is valid (1..4), else 0.
std::size_t utf8_sequence_length(std::string_view s, std::size_t i) noexcept {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b0 = byte(i);
  if (b0 < 0x80) return 1;
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // allowed range of the second byte
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    n = 2;
  } else if (b0 >= 0xE0 && b0 <= 0xEF) {
    n = 3;
    if (b0 == 0xE0) lo = 0xA0;  // overlong
    if (b0 == 0xED) hi = 0x9F;  // surrogates
  } else if (b0 >= 0xF0 && b0 <= 0xF4) {
    n = 4;
    if (b0 == 0xF0) lo = 0x90;  // overlong
    if (b0 == 0xF4) hi = 0x8F;  // above U+10FFFF
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  if (byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
  }
  return n;
}

bool is_control(unsigned char c) noexcept {
  return c < 0x20 || c == 0x7F;
}

}  // namespace

std::size_t copy_wire_string(std::string_view in, char* out, std::size_t capacity) noexcept {
  std::size_t written = 0;
  std::size_t i = 0;
  while (i < in.size()) {
    const std::size_t n = utf8_sequence_length(in, i);
    if (n == 0) {
      if (written + 1 > capacity) break;
      out[written++] = '?';
      ++i;
      continue;
    }
    if (written + n > capacity) break;
    if (n == 1 && is_control(static_cast<unsigned char>(in[i]))) {
      out[written++] = ' ';
    } else {
      for (std::size_t k = 0; k < n; ++k)
        out[written++] = in[i + k];
    }
    i += n;
  }
  return written;
}

bool is_wire_string(std::string_view s) noexcept {
  std::size_t i = 0;
  while (i < s.size()) {
    // Printable ASCII (0x20..0x7E), most of any string, without the sequence's decoding.
    if (static_cast<unsigned char>(s[i]) - 0x20u < 0x5Fu) {
      ++i;
      continue;
    }
    const std::size_t n = utf8_sequence_length(s, i);
    if (n == 0) return false;
    if (n == 1 && is_control(static_cast<unsigned char>(s[i]))) return false;
    i += n;
  }
  return true;
}

MessageType type_of(const Message& m) noexcept {
  return detail::kMessageTable[m.index()].type;
}

bool is_request(MessageType t) noexcept {
  const auto* row = detail::find_message(t);
  return row != nullptr && row->direction == detail::Direction::kHostToDaemon;
}

std::uint8_t minor_of(MessageType t) noexcept {
  const auto* row = detail::find_message(t);
  return row == nullptr ? 255 : row->since;
}

std::string_view to_string(MessageType t) noexcept {
  const auto* row = detail::find_message(t);
  return row == nullptr ? "Unknown" : row->name;
}

const MessagePolicy& policy_of(MessageType t) noexcept {
  static constexpr MessagePolicy kUnknown{};
  const auto* row = detail::find_message(t);
  return row == nullptr ? kUnknown : row->policy;
}

std::span<const Refusal> refusals_of(MessageType t) noexcept {
  const auto* row = detail::find_message(t);
  return row == nullptr ? std::span<const Refusal>{} : row->refusals;
}

bool names_field(const Refusal& r, std::string_view field) noexcept {
  if (!field.starts_with(r.field)) return false;
  field.remove_prefix(r.field.size());
  if (r.indexed) {  // "[digits]"
    if (!field.starts_with('[')) return false;
    const std::size_t close = field.find(']');
    if (close == std::string_view::npos || close < 2) return false;
    for (std::size_t i = 1; i < close; ++i)
      if (field[i] < '0' || field[i] > '9') return false;
    field.remove_prefix(close + 1);
  }
  if (r.per_axis) return field == ".x" || field == ".y" || field == ".z";
  return field.empty();
}

const Refusal* find_refusal(MessageType t, ErrorCode code, std::string_view field) noexcept {
  for (const Refusal& r : refusals_of(t))
    if (r.code == code && names_field(r, field)) return &r;
  return nullptr;
}

std::string field_pattern(const Refusal& r) {
  if (r.field.empty()) return "–";
  std::string s(r.field);
  if (r.indexed) s += "[i]";
  if (r.per_axis) s += ".{x,y,z}";
  return s;
}

}  // namespace ajar::protocol
