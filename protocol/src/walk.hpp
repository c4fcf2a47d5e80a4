// Walks a value along its Schema (message_schema.hpp) and hands every wire field, with its
// composed name, to an IO: the Writer (encode), the Reader (decode and check), the layout lister.
// IO provides since(minor) and minor(), scalar<WireType>(value, name), str(value, name),
// bytes(value, name), and for
// the fields that size a payload sizes(valid, code, name, value, reason) (false: stop) and
// body<T>(variant) (nullptr: stop). S is `const T` when encoding and `T` when decoding. A walk
// returns false where it stopped early: at the first field a minor version appended that the
// layout being walked does not have, or at a size field that failed.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>
#include <variant>

#include "little_endian.hpp"
#include "message_schema.hpp"

namespace ajar::protocol::detail {

// The walk is inlined whole into each message's encoder and decoder (codec.cpp: one function per
// message type), as hand-written field code would be; with the helpers it calls always inlined
// too, encode and decode are as fast as the hand-written codec was (tests/bench/protocol_bench).
#define AJAR_WALK_INLINE [[gnu::always_inline]] inline

template <typename T>
struct IsStdArray : std::false_type {};
template <typename T, std::size_t N>
struct IsStdArray<std::array<T, N>> : std::true_type {};
template <typename T>
struct IsFixedString : std::false_type {};
template <std::size_t N>
struct IsFixedString<FixedString<N>> : std::true_type {};
template <typename T>
struct IsFixedBytes : std::false_type {};
template <std::size_t N>
struct IsFixedBytes<FixedBytes<N>> : std::true_type {};
template <typename T>
struct KindArgument;
template <template <auto> typename K, auto M>
struct KindArgument<K<M>> {
  static constexpr auto member = M;
};

template <Text Prefix, typename IO, typename S>
AJAR_WALK_INLINE bool walk(IO& io, S& s) noexcept;

// Ack.acknowledged sizes the Ack: it must be a request type that protocol 1.`minor` has. Its row,
// or nullptr.
AJAR_WALK_INLINE const MessageInfo* acked_row(MessageType t, std::uint8_t minor) noexcept {
  const MessageInfo* row = find_message(t);
  return row != nullptr && row->direction == Direction::kHostToDaemon && row->since <= minor
             ? row
             : nullptr;
}

// Elements [0, count) of an array, named Name[i].
template <Text Name, typename IO, typename A, std::size_t... I>
AJAR_WALK_INLINE void walk_elements(IO& io, A& array, std::size_t count,
                                    std::index_sequence<I...>) noexcept;

// One value named Name, by its C++ type.
template <Text Name, typename IO, typename V>
AJAR_WALK_INLINE bool walk_value(IO& io, V& v) noexcept {
  using T = std::remove_const_t<V>;
  constexpr const char* n = c_str<Name>();
  if constexpr (!std::is_void_v<WireOf<T>>) {
    io.template scalar<WireOf<T>>(v, n);
  } else if constexpr (IsFixedString<T>::value) {
    io.str(v, n);
  } else if constexpr (IsFixedBytes<T>::value) {
    io.bytes(v, n);
  } else if constexpr (std::is_same_v<T, core::Vec3>) {
    walk_value<Name + Text(".x")>(io, v.x());
    walk_value<Name + Text(".y")>(io, v.y());
    walk_value<Name + Text(".z")>(io, v.z());
  } else if constexpr (std::is_same_v<T, core::FramedPoint>) {  // Point: frame, x, y, z
    walk_value<Name + Text(".frame")>(io, v.frame);
    walk_value<Name>(io, v.position_m);
  } else if constexpr (IsStdArray<T>::value) {
    walk_elements<Name>(io, v, v.size(), std::make_index_sequence<std::tuple_size_v<T>>{});
  } else {
    return walk<Name + Text(".")>(io, v);
  }
  return true;
}

template <Text Name, typename IO, typename A, std::size_t... I>
AJAR_WALK_INLINE void walk_elements(IO& io, A& array, std::size_t count,
                                    std::index_sequence<I...>) noexcept {
  ((I < count ? static_cast<void>(walk_value<Name + index_text<I>()>(io, array[I]))
              : static_cast<void>(0)),
   ...);
}

// The Ack's body: the AckBody alternative that the acknowledged type's Schema names (ack_body),
// by message table row. The walk dispatches on it (five alternatives, inlined), not on the message
// type (thirty, an indirect call that left the IO in memory).
template <typename T, typename... A>
consteval std::uint8_t alternative_index(std::type_identity<std::variant<A...>>) {
  std::uint8_t i = 0;
  static_cast<void>(((std::is_same_v<T, A> ? false : (++i, true)) && ...));
  return i;
}
inline constexpr auto kAckBodyOfRow = []<std::size_t... I>(std::index_sequence<I...>) {
  return std::array<std::uint8_t, sizeof...(I)>{
      alternative_index<typename Schema<std::variant_alternative_t<I, Message>>::ack_body>(
          std::type_identity<AckBody>{})...};
}
(std::make_index_sequence<std::variant_size_v<Message>>{});
static_assert(std::ranges::all_of(kAckBodyOfRow,
                                  [](std::uint8_t i) { return i < std::variant_size_v<AckBody>; }),
              "every Schema's ack_body is an alternative of AckBody");

// Body alternative B of an Ack (v: its AckBody), through io.body<B>() and walked; and the same
// by the alternative's index.
template <typename B, typename IO, typename V>
AJAR_WALK_INLINE bool walk_ack_body_as(IO& io, V& v) noexcept {
  auto* body = io.template body<B>(v);
  return body != nullptr && walk<Text("")>(io, *body);
}
template <typename IO, typename V, std::size_t... I>
AJAR_WALK_INLINE bool walk_ack_body(IO& io, V& v, std::uint8_t index,
                                    std::index_sequence<I...>) noexcept {
  bool walked = true;
  static_cast<void>(
      ((I == index &&
        (walked = walk_ack_body_as<std::variant_alternative_t<I, AckBody>>(io, v), true)) ||
       ...));
  return walked;
}

template <Text Prefix, typename F, typename IO, typename S>
AJAR_WALK_INLINE bool walk_field(IO& io, S& s) noexcept {
  if (!io.since(F::since)) return false;  // the layout ends where this minor's fields start
  auto& v = s.*(F::member);
  constexpr auto name = Prefix + F::name;
  using K = typename F::kind;
  if constexpr (std::is_same_v<K, Plain>) {
    return walk_value<name>(io, v);
  } else if constexpr (IsWire<K>::value) {
    io.template scalar<K>(v, c_str<name>());
    return true;
  } else if constexpr (std::is_same_v<K, PlaneCount>) {
    walk_value<name>(io, v);
    return io.sizes(valid_plane_count(v), ErrorCode::kBadCount, c_str<name>(), v, "");
  } else if constexpr (std::is_same_v<K, AckedType>) {
    walk_value<name>(io, v);
    return io.sizes(acked_row(v, io.minor()) != nullptr, ErrorCode::kInvalidEnumValue,
                    c_str<name>(), static_cast<std::uint16_t>(v), "acknowledged");
  } else if constexpr (std::is_same_v<K, CountedBy<KindArgument<K>::member>>) {
    using A = std::remove_cvref_t<decltype(v)>;
    walk_elements<name>(io, v, s.*(KindArgument<K>::member),
                        std::make_index_sequence<std::tuple_size_v<A>>{});
    return true;
  } else {
    static_assert(std::is_same_v<K, AckBodyOf<KindArgument<K>::member>>);
    // The body's fields are named without a prefix ("length_m", "normal.x"). A type the table
    // does not have walks no body.
    const MessageInfo* row = find_message(s.*(KindArgument<K>::member));
    if (row == nullptr) return true;
    return walk_ack_body(io, v, kAckBodyOfRow[static_cast<std::size_t>(row - kMessageTable.data())],
                         std::make_index_sequence<std::variant_size_v<AckBody>>{});
  }
}

template <Text Prefix, typename IO, typename S, typename... F>
AJAR_WALK_INLINE bool walk_fields(IO& io, S& s, Fields<F...> fields) noexcept {
  static_assert(appended_at_the_end(fields), "appended fields come last, newest last");
  return (walk_field<Prefix, F>(io, s) && ...);
}

template <Text Prefix, typename IO, typename S>
AJAR_WALK_INLINE bool walk(IO& io, S& s) noexcept {
  return walk_fields<Prefix>(io, s, typename Schema<std::remove_const_t<S>>::fields{});
}

// ---- the length of a layout, from the same tables, without a value ---------------------------
// The decoder's fast path (codec.cpp) reads a payload without a bounds check per field once its
// length is known to be the layout's; these give that length. wire_size<V>() is walk_value's
// cases counted: the bytes a V takes. payload_size<S>() is walk's fields counted in protocol
// 1.`minor`, with the fields that size the payload (MeasureDoorPlane.count, Ack.acknowledged)
// read from the payload; kNoSize when one of those is not in the payload or is invalid (the
// checked walk reports it). tests/protocol compares both with payload_layout() for every sample
// in every minor.

inline constexpr std::size_t kNoSize = static_cast<std::size_t>(-1);

template <typename S, typename F>
using MemberOf = std::remove_cvref_t<decltype(std::declval<S&>().*(F::member))>;

template <typename V>
consteval std::size_t wire_size();

template <typename S, typename F>
consteval std::size_t fixed_field_size() {
  static_assert(F::since == 0, "a nested structure's fields are all in its first layout");
  if constexpr (IsWire<typename F::kind>::value) {
    return sizeof(typename F::kind::raw);
  } else {
    static_assert(std::is_same_v<typename F::kind, Plain>, "a nested structure has a fixed size");
    return wire_size<MemberOf<S, F>>();
  }
}
template <typename S, typename... F>
consteval std::size_t fixed_fields_size(Fields<F...>) {
  return (fixed_field_size<S, F>() + ... + 0);
}

template <typename V>
consteval std::size_t wire_size() {
  using T = std::remove_const_t<V>;
  if constexpr (!std::is_void_v<WireOf<T>>) {
    return sizeof(typename WireOf<T>::raw);
  } else if constexpr (IsFixedString<T>::value) {
    return 1 + std::tuple_size_v<decltype(T::bytes)>;
  } else if constexpr (IsFixedBytes<T>::value) {
    return 2 + std::tuple_size_v<decltype(T::bytes)>;
  } else if constexpr (std::is_same_v<T, core::Vec3>) {
    return 3 * wire_size<double>();
  } else if constexpr (std::is_same_v<T, core::FramedPoint>) {
    return wire_size<core::Frame>() + wire_size<core::Vec3>();
  } else if constexpr (IsStdArray<T>::value) {
    return std::tuple_size_v<T> * wire_size<typename T::value_type>();
  } else {
    return fixed_fields_size<T>(typename Schema<T>::fields{});
  }
}

// The Ack body's length by message table row (0: the empty body, and rows without a body).
inline constexpr auto kAckBodySize = []<std::size_t... I>(std::index_sequence<I...>) {
  return std::array<std::size_t, sizeof...(I)>{
      wire_size<typename Schema<std::variant_alternative_t<I, Message>>::ack_body>()...};
}
(std::make_index_sequence<std::variant_size_v<Message>>{});

struct SizeWalk {
  const std::uint8_t* p;
  std::size_t size;
  std::uint8_t minor;
  std::size_t offset = 0;
  std::size_t count = 0;  // the last PlaneCount read
  std::size_t body = 0;   // the Ack body's length, from the last AckedType read
  bool sized = true;
};
// Counts field F of S; false: the layout ends here (a newer minor's field, or a size field that
// is missing or invalid: then sized is false).
template <typename S, typename F>
AJAR_WALK_INLINE bool size_field(SizeWalk& w) noexcept {
  if (w.minor < F::since) return false;
  using V = MemberOf<S, F>;
  using K = typename F::kind;
  if constexpr (std::is_same_v<K, Plain>) {
    w.offset += wire_size<V>();
  } else if constexpr (IsWire<K>::value) {
    w.offset += sizeof(typename K::raw);
  } else if constexpr (std::is_same_v<K, PlaneCount> || std::is_same_v<K, AckedType>) {
    using W = WireOf<V>;
    using Raw = typename W::raw;
    if (w.size < w.offset + sizeof(Raw)) return w.sized = false;
    const V v = W::template from_raw<V>(load<Raw>(w.p + w.offset));
    if constexpr (std::is_same_v<K, PlaneCount>) {
      if (!valid_plane_count(v)) return w.sized = false;
      w.count = v;
    } else {
      const MessageInfo* row = acked_row(v, w.minor);
      if (row == nullptr) return w.sized = false;
      w.body = kAckBodySize[static_cast<std::size_t>(row - kMessageTable.data())];
    }
    w.offset += sizeof(Raw);
  } else if constexpr (std::is_same_v<K, CountedBy<KindArgument<K>::member>>) {
    w.offset += w.count * wire_size<typename V::value_type>();
  } else {
    w.offset += w.body;
  }
  return true;
}
template <typename S, typename... F>
AJAR_WALK_INLINE std::size_t payload_size(SizeWalk& w, Fields<F...>) noexcept {
  static_cast<void>((size_field<S, F>(w) && ...));
  return w.sized ? w.offset : kNoSize;
}
template <typename S>
AJAR_WALK_INLINE std::size_t payload_size(const std::uint8_t* p, std::size_t size,
                                          std::uint8_t minor) noexcept {
  SizeWalk w{p, size, minor};
  return payload_size<S>(w, typename Schema<S>::fields{});
}

}  // namespace ajar::protocol::detail

#undef AJAR_WALK_INLINE
