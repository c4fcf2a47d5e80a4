// The vocabulary of the message tables (message_schema.hpp): a field is a name, a member and the
// minor version that appended it; a message is a row (type, name, direction, minor) plus its
// fields. walk.hpp turns one such description into the writer, the reader with its checks, and
// the layout listing, so none of them repeats a field.
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <type_traits>

#include "ajar/protocol/message_table.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::protocol::detail {

// A string usable as a template argument. Names compose at compile time ("width" + "." +
// "length_m"); every composed name is a template parameter object, so it has static storage
// (DecodeError::field is a const char*).
template <std::size_t N>
struct Text {
  std::array<char, N> chars{};  // zero terminated
  constexpr Text() = default;
  constexpr Text(const char (&s)[N]) {  // NOLINT: implicit, from a literal
    for (std::size_t i = 0; i < N; ++i)
      chars[i] = s[i];
  }
  constexpr std::string_view view() const { return {chars.data(), N - 1}; }
};
template <std::size_t A, std::size_t B>
constexpr Text<A + B - 1> operator+(const Text<A>& a, const Text<B>& b) {
  Text<A + B - 1> out;
  for (std::size_t i = 0; i + 1 < A; ++i)
    out.chars[i] = a.chars[i];
  for (std::size_t i = 0; i < B; ++i)
    out.chars[A - 1 + i] = b.chars[i];
  return out;
}
// "[I]", for array elements.
template <std::size_t I>
constexpr auto index_text() {
  static_assert(I < 100);
  if constexpr (I < 10) {
    Text<4> t;
    t.chars = {'[', static_cast<char>('0' + I), ']', '\0'};
    return t;
  } else {
    Text<5> t;
    t.chars = {'[', static_cast<char>('0' + I / 10), static_cast<char>('0' + I % 10), ']', '\0'};
    return t;
  }
}
// The static, zero-terminated storage of a name.
template <Text N>
constexpr const char* c_str() noexcept {
  return N.chars.data();
}

// How a field goes on the wire. kPlain: as its C++ type says (integers, f32/f64, bool, enums with
// their value count, ErrorCode and MessageType as raw u16, FixedString<N>, Vec3, FramedPoint,
// std::array, or a struct with its own Schema, whose field names get this field's name as prefix).
// A Wire type (below) as Kind writes the field as that type.
struct Plain {};
struct PlaneCount {};  // u8 3..16 that sizes the payload (BAD_COUNT)
struct AckedType {};   // u16 host -> daemon type of the frame's minor that sizes the Ack body
template <auto CountMember>
struct CountedBy {};  // array elements [0, parent.*CountMember)
template <auto TypeMember>
struct AckBodyOf {};  // the body Schema<request>::ack_body of the request type parent.*TypeMember

// One field: its wire name, the member it reads and writes, the minor version that appended it
// (0: in the 1.0 layout), how it is written.
template <Text Name, auto Member, std::uint8_t Since = 0, typename Kind = Plain>
struct Field {
  static constexpr auto name = Name;
  static constexpr auto member = Member;
  static constexpr std::uint8_t since = Since;
  using kind = Kind;
};

template <typename... F>
struct Fields {};
template <typename... Lists>
struct ConcatFields;
template <typename... A>
struct ConcatFields<Fields<A...>> {
  using type = Fields<A...>;
};
template <typename... A, typename... B, typename... Rest>
struct ConcatFields<Fields<A...>, Fields<B...>, Rest...> {
  using type = typename ConcatFields<Fields<A..., B...>, Rest...>::type;
};
template <typename... Lists>
using Concat = typename ConcatFields<Lists...>::type;

// Fields appended by a minor version come after every field of the older layout, so the older
// layout is the newer one cut where the appended fields start (docs/protocol.md section 7).
template <typename... F>
constexpr bool appended_at_the_end(Fields<F...>) {
  const std::array<std::uint8_t, sizeof...(F) + 1> since{0, F::since...};
  for (std::size_t i = 1; i < since.size(); ++i) {
    if (since[i] < since[i - 1] || since[i] > kVersionMinor) return false;
  }
  return true;
}

enum class Direction : std::uint8_t { kHostToDaemon, kDaemonToHost };

// The row of a message in the message table. Schema<T> of a message derives from its row and adds
// `fields` (and, for a request, `ack_body`: what its Ack carries, `policy`: who may send it and
// how the daemon treats it, and `refusals`: the Errors the daemon may answer it with,
// message_table.hpp).
template <MessageType Type, Text Name, Direction Dir, std::uint8_t Since>
struct MessageRow {
  static constexpr MessageType type = Type;
  static constexpr auto name = Name;
  static constexpr Direction direction = Dir;
  static constexpr std::uint8_t since = Since;
  static constexpr MessagePolicy policy{};             // a request's Schema gives its own
  static constexpr std::array<Refusal, 0> refusals{};  // a request's Schema gives its own
  using ack_body = EmptyAck;
  static_assert((static_cast<std::uint16_t>(Type) >> 8) ==
                    (Dir == Direction::kHostToDaemon ? 1 : 2),
                "host -> daemon types are 0x01xx, daemon -> host types 0x02xx");
};

// Schema<T>::fields lists T's wire fields in wire order; a message's Schema also is its row.
template <typename T>
struct Schema;

// The number of values of an enum on the wire (values are 0..count-1): from the words of a protocol
// enum (EnumWords, messages.hpp), from the last enumerator of a core enum (EnumLast).
template <typename E>
struct EnumLast {
  static constexpr auto last = EnumWords<E>::last;
};
template <typename E>
constexpr std::uint8_t enum_count() {
  constexpr auto count = static_cast<std::size_t>(EnumLast<E>::last) + 1;
  if constexpr (requires { EnumWords<E>::words; }) {
    static_assert(EnumWords<E>::words.size() == count, "every enumerator has its word");
  }
  return static_cast<std::uint8_t>(count);
}

// ---- wire types -----------------------------------------------------------------------------
// Every scalar field goes on the wire as one of these: its raw unsigned type (the size), the name
// the layout tables of docs/protocol.md use, and the check a decoded raw value must pass. The
// Writer, the Reader and the layout lister know nothing else about a scalar.

// What is wrong with a decoded raw value (code kOk: nothing), as DecodeError reports it.
struct Problem {
  ErrorCode code = ErrorCode::kOk;
  std::uint64_t limit = 0;
  const char* reason = "";
};
using Check = Problem (*)(std::uint64_t raw) noexcept;

[[gnu::always_inline]] constexpr Problem any_value(std::uint64_t) noexcept {
  return {};
}
[[gnu::always_inline]] constexpr Problem zero_or_one(std::uint64_t raw) noexcept {
  return raw <= 1 ? Problem{} : Problem{ErrorCode::kInvalidEnumValue, 2, "bool"};
}
[[gnu::always_inline]] constexpr Problem plus_or_minus_one(std::uint64_t raw) noexcept {
  const auto v = static_cast<std::int8_t>(raw);
  return v == 1 || v == -1 ? Problem{} : Problem{ErrorCode::kInvalidEnumValue, 0, "polarity"};
}
template <std::uint8_t Count>
[[gnu::always_inline]] constexpr Problem below(std::uint64_t raw) noexcept {
  return raw < Count ? Problem{} : Problem{ErrorCode::kInvalidEnumValue, Count};
}
template <typename Float, typename Raw>
[[gnu::always_inline]] inline Problem finite(
    std::uint64_t raw) noexcept {  // limit: the size, for describe()
  return std::isfinite(std::bit_cast<Float>(static_cast<Raw>(raw)))
             ? Problem{}
             : Problem{ErrorCode::kNonFiniteNumber, sizeof(Raw)};
}

[[gnu::always_inline]] constexpr Problem list_count(std::uint64_t raw) noexcept {
  return raw <= kRecordingListEntries
             ? Problem{}
             : Problem{ErrorCode::kBadCount, kRecordingListEntries, "entries"};
}

// A value to its raw bits and back: floats bit for bit, integers, bools and enums by value.
template <typename To, typename From>
[[gnu::always_inline]] constexpr To convert(From v) noexcept {
  if constexpr (std::is_floating_point_v<To> || std::is_floating_point_v<From>) {
    return std::bit_cast<To>(v);
  } else {
    return static_cast<To>(v);
  }
}

template <typename Raw, Text Name, Check Validate = &any_value>
struct Wire {
  using raw = Raw;
  static constexpr auto name = Name;
  template <typename V>
  [[gnu::always_inline]] static Raw to_raw(V v) noexcept {
    return convert<Raw>(v);
  }
  template <typename V>
  [[gnu::always_inline]] static V from_raw(Raw r) noexcept {
    return convert<V>(r);
  }
  [[gnu::always_inline]] static Problem check(Raw r) noexcept { return Validate(r); }
};
template <typename T>
struct IsWire : std::false_type {};
template <typename Raw, Text Name, Check Validate>
struct IsWire<Wire<Raw, Name, Validate>> : std::true_type {};

template <std::size_t N>
constexpr auto decimal_text() {
  if constexpr (N < 10) {
    Text<2> t;
    t.chars = {static_cast<char>('0' + N), '\0'};
    return t;
  } else {
    return decimal_text<N / 10>() + decimal_text<N % 10>();
  }
}

// A WheelModel polarity: +1 or -1 as a signed byte.
using Polarity = Wire<std::uint8_t, "i8", &plus_or_minus_one>;

// RecordingList.count (1.2): 0..kRecordingListEntries, else BAD_COUNT (not a size field: the list
// always has all its entries).
using ListCount = Wire<std::uint8_t, "u8", &list_count>;

// The wire type of a C++ field type (void: not a scalar).
template <typename T>
constexpr auto wire_of() {
  if constexpr (std::is_same_v<T, bool>) {
    return Wire<std::uint8_t, "bool", &zero_or_one>{};
  } else if constexpr (std::is_floating_point_v<T>) {
    using Raw = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
    return Wire<Raw, Text("f") + decimal_text<8 * sizeof(T)>(), &finite<T, Raw>>{};
  } else if constexpr (std::is_same_v<T, std::int64_t>) {
    return Wire<std::uint64_t, "i64">{};  // two's complement
  } else if constexpr (std::is_same_v<T, ErrorCode> || std::is_same_v<T, MessageType>) {
    // Not checked: a newer peer may send codes and types this version does not know (clients
    // treat an unknown code as a generic failure; Ack.acknowledged is checked as a size field).
    return Wire<std::uint16_t, "u16">{};
  } else if constexpr (std::is_enum_v<T>) {
    return Wire<std::uint8_t, "u8", &below<enum_count<T>()>>{};
  } else if constexpr (std::is_unsigned_v<T>) {
    return Wire<T, Text("u") + decimal_text<8 * sizeof(T)>()>{};
  }
}
template <typename T>
using WireOf = decltype(wire_of<T>());

// The fields that size a payload, checked alike by every end.
constexpr bool valid_plane_count(std::uint8_t count) noexcept {
  return count >= kMinPlanePoints && count <= kMaxPlanePoints;
}

}  // namespace ajar::protocol::detail
