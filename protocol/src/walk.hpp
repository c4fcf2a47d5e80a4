// Walks a value along its Schema (message_schema.hpp) and hands every wire field, with its
// composed name, to an IO: the Writer (encode), the Reader (decode and check), the layout lister.
// IO provides since(minor) and minor(), scalar<WireType>(value, name), str(value, name),
// bytes(value, name), and for
// the fields that size a payload sizes(valid, code, name, value, reason) (false: stop) and
// body<T>(variant) (nullptr: stop). S is `const T` when encoding and `T` when decoding. A walk
// returns false where it stopped early: at the first field a minor version appended that the
// layout being walked does not have, or at a size field that failed.
#pragma once

#include <cstddef>
#include <type_traits>
#include <utility>

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
    return io.sizes(is_request(v) && minor_of(v) <= io.minor(), ErrorCode::kInvalidEnumValue,
                    c_str<name>(), static_cast<std::uint16_t>(v), "acknowledged");
  } else if constexpr (std::is_same_v<K, CountedBy<KindArgument<K>::member>>) {
    using A = std::remove_cvref_t<decltype(v)>;
    walk_elements<name>(io, v, s.*(KindArgument<K>::member),
                        std::make_index_sequence<std::tuple_size_v<A>>{});
    return true;
  } else {
    static_assert(std::is_same_v<K, AckBodyOf<KindArgument<K>::member>>);
    // The body's fields are named without a prefix ("length_m", "normal.x").
    bool walked = true;
    with_message_type(s.*(KindArgument<K>::member), [&]<typename R>(Alternative<R>) {
      using Body = typename Schema<R>::ack_body;
      auto* body = io.template body<Body>(v);
      walked = body != nullptr && walk<Text("")>(io, *body);
    });
    return walked;
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

}  // namespace ajar::protocol::detail

#undef AJAR_WALK_INLINE
