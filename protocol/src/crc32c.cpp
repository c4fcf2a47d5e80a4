#include "ajar/protocol/crc32c.hpp"

#include <array>
#include <atomic>
#include <cstring>

#include "ajar/core/words.hpp"

#if defined(__x86_64__)
#include <cpuid.h>
#include <nmmintrin.h>
#elif defined(__aarch64__)
#include <arm_acle.h>
#include <sys/auxv.h>
#ifndef HWCAP_CRC32
#define HWCAP_CRC32 (1 << 7)
#endif
// GCC's arm_acle.h declares __crc32c* for any target; clang's only when the whole file is built
// with +crc, so clang uses its builtins inside a function compiled for the extension.
#if defined(__clang__)
#define AJAR_TARGET_CRC __attribute__((target("crc")))
#define AJAR_CRC32CD __builtin_arm_crc32cd
#define AJAR_CRC32CB __builtin_arm_crc32cb
#else
#define AJAR_TARGET_CRC __attribute__((target("+crc")))
#define AJAR_CRC32CD __crc32cd
#define AJAR_CRC32CB __crc32cb
#endif
#endif

namespace ajar::protocol {
namespace {

using UpdateFn = std::uint32_t (*)(std::uint32_t, const std::uint8_t*, std::size_t) noexcept;

constexpr std::uint32_t kPolynomialReflected = 0x82F63B78u;

// Slicing-by-8: table[k][b] is the CRC register after byte b followed by k zero bytes.
constexpr std::array<std::array<std::uint32_t, 256>, 8> make_tables() {
  std::array<std::array<std::uint32_t, 256>, 8> t{};
  for (std::uint32_t b = 0; b < 256; ++b) {
    std::uint32_t c = b;
    for (int i = 0; i < 8; ++i)
      c = (c >> 1) ^ ((c & 1u) != 0 ? kPolynomialReflected : 0u);
    t[0][b] = c;
  }
  for (std::size_t k = 1; k < 8; ++k)
    for (std::size_t b = 0; b < 256; ++b)
      t[k][b] = (t[k - 1][b] >> 8) ^ t[0][t[k - 1][b] & 0xFFu];
  return t;
}
constexpr auto kTables = make_tables();

std::uint32_t update_table(std::uint32_t crc, const std::uint8_t* p, std::size_t n) noexcept {
  while (n >= 8) {
    const std::uint32_t lo =
        crc ^ (static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
               static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24);
    crc = kTables[7][lo & 0xFFu] ^ kTables[6][(lo >> 8) & 0xFFu] ^ kTables[5][(lo >> 16) & 0xFFu] ^
          kTables[4][lo >> 24] ^ kTables[3][p[4]] ^ kTables[2][p[5]] ^ kTables[1][p[6]] ^
          kTables[0][p[7]];
    p += 8;
    n -= 8;
  }
  while (n-- > 0)
    crc = (crc >> 8) ^ kTables[0][(crc ^ *p++) & 0xFFu];
  return crc;
}

#if defined(__x86_64__)
__attribute__((target("sse4.2"))) std::uint32_t update_sse42(std::uint32_t crc,
                                                             const std::uint8_t* p,
                                                             std::size_t n) noexcept {
  std::uint64_t c = crc;
  while (n >= 8) {
    std::uint64_t v;  // x86 is little-endian: the instruction takes the bytes in memory order
    std::memcpy(&v, p, sizeof v);
    c = _mm_crc32_u64(c, v);
    p += 8;
    n -= 8;
  }
  auto c32 = static_cast<std::uint32_t>(c);
  if (n >= 4) {
    std::uint32_t v;
    std::memcpy(&v, p, sizeof v);
    c32 = _mm_crc32_u32(c32, v);
    p += 4;
    n -= 4;
  }
  while (n-- > 0)
    c32 = _mm_crc32_u8(c32, *p++);
  return c32;
}

bool cpu_has_sse42() noexcept {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  if (__get_cpuid(1, &eax, &ebx, &ecx, &edx) == 0) return false;
  return (ecx & bit_SSE4_2) != 0;
}
#elif defined(__aarch64__)
AJAR_TARGET_CRC std::uint32_t update_armv8(std::uint32_t crc, const std::uint8_t* p,
                                           std::size_t n) noexcept {
  while (n >= 8) {
    std::uint64_t v;  // little-endian arm64 (the only arm64 ABI Debian ships)
    std::memcpy(&v, p, sizeof v);
    crc = AJAR_CRC32CD(crc, v);
    p += 8;
    n -= 8;
  }
  while (n-- > 0)
    crc = AJAR_CRC32CB(crc, *p++);
  return crc;
}

bool cpu_has_armv8_crc() noexcept {
  return (getauxval(AT_HWCAP) & HWCAP_CRC32) != 0;
}
#endif

UpdateFn function_of(Crc32cPath path) noexcept {
  switch (path) {
#if defined(__x86_64__)
    case Crc32cPath::kSse42:
      return &update_sse42;
#elif defined(__aarch64__)
    case Crc32cPath::kArmv8:
      return &update_armv8;
#endif
    default:
      return &update_table;
  }
}

Crc32cPath best_path() noexcept {
#if defined(__x86_64__)
  if (cpu_has_sse42()) return Crc32cPath::kSse42;
#elif defined(__aarch64__)
  if (cpu_has_armv8_crc()) return Crc32cPath::kArmv8;
#endif
  return Crc32cPath::kTable;
}

std::uint32_t update_first_call(std::uint32_t crc, const std::uint8_t* p, std::size_t n) noexcept;

// Starts at a resolver that picks the best path on first use (no static-initialisation order
// dependency); relaxed atomics: every thread that resolves stores the same value.
std::atomic<UpdateFn> g_update{&update_first_call};
std::atomic<Crc32cPath> g_path{Crc32cPath::kTable};

void select(Crc32cPath path) noexcept {
  g_path.store(path, std::memory_order_relaxed);
  g_update.store(function_of(path), std::memory_order_relaxed);
}

std::uint32_t update_first_call(std::uint32_t crc, const std::uint8_t* p, std::size_t n) noexcept {
  const Crc32cPath path = best_path();
  select(path);
  return function_of(path)(crc, p, n);
}

}  // namespace

std::string_view to_string(Crc32cPath path) noexcept {
  constexpr Word<Crc32cPath> kWords[] = {
      {Crc32cPath::kTable, "table"}, {Crc32cPath::kSse42, "sse4.2"}, {Crc32cPath::kArmv8, "armv8"}};
  return word_of(kWords, path, "?");
}

bool crc32c_available(Crc32cPath path) noexcept {
  switch (path) {
    case Crc32cPath::kTable:
      return true;
#if defined(__x86_64__)
    case Crc32cPath::kSse42:
      return cpu_has_sse42();
#elif defined(__aarch64__)
    case Crc32cPath::kArmv8:
      return cpu_has_armv8_crc();
#endif
    default:
      return false;
  }
}

Crc32cPath crc32c_path() noexcept {
  if (g_update.load(std::memory_order_relaxed) == &update_first_call) select(best_path());
  return g_path.load(std::memory_order_relaxed);
}

bool force_crc32c_path(Crc32cPath path) noexcept {
  if (!crc32c_available(path)) return false;
  select(path);
  return true;
}

std::uint32_t crc32c_update(std::uint32_t crc, const std::uint8_t* data,
                            std::size_t size) noexcept {
  return g_update.load(std::memory_order_relaxed)(crc, data, size);
}

std::uint32_t crc32c_update_with(Crc32cPath path, std::uint32_t crc, const std::uint8_t* data,
                                 std::size_t size) noexcept {
  return function_of(path)(crc, data, size);
}

std::uint32_t crc32c(std::span<const std::uint8_t> bytes) noexcept {
  return crc32c_finish(crc32c_update(kCrc32cInit, bytes.data(), bytes.size()));
}

}  // namespace ajar::protocol
