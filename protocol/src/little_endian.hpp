// Little-endian byte helpers (always inlined: they are a load or a store) shared by the frame
// header (codec.cpp) and the payload fields (field_io.hpp). Written as shifted bytes: compilers
// turn them into single loads and stores.
#pragma once

#include <cstdint>

namespace ajar::protocol::detail {

[[gnu::always_inline]] inline void put_u16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
[[gnu::always_inline]] inline void put_u32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i)
    p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
[[gnu::always_inline]] inline void put_u64(std::uint8_t* p, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i)
    p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
[[gnu::always_inline]] inline std::uint16_t get_u16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
[[gnu::always_inline]] inline std::uint32_t get_u32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
[[gnu::always_inline]] inline std::uint64_t get_u64(const std::uint8_t* p) noexcept {
  return static_cast<std::uint64_t>(get_u32(p)) |
         (static_cast<std::uint64_t>(get_u32(p + 4)) << 32);
}

// The same by the size of Raw (an unsigned integer of 1, 2, 4 or 8 bytes).
template <typename Raw>
[[gnu::always_inline]] inline void store(std::uint8_t* p, Raw v) noexcept {
  if constexpr (sizeof(Raw) == 1) {
    p[0] = v;
  } else if constexpr (sizeof(Raw) == 2) {
    put_u16(p, v);
  } else if constexpr (sizeof(Raw) == 4) {
    put_u32(p, v);
  } else {
    put_u64(p, v);
  }
}
template <typename Raw>
[[gnu::always_inline]] inline Raw load(const std::uint8_t* p) noexcept {
  if constexpr (sizeof(Raw) == 1) {
    return p[0];
  } else if constexpr (sizeof(Raw) == 2) {
    return get_u16(p);
  } else if constexpr (sizeof(Raw) == 4) {
    return get_u32(p);
  } else {
    return get_u64(p);
  }
}

}  // namespace ajar::protocol::detail
