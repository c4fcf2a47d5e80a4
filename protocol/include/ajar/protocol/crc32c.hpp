// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78, init and final xor 0xFFFFFFFF), the frame
// checksum. Three implementations give identical results: the CPU instruction (x86-64 SSE4.2
// `crc32`; arm64 ARMv8 `crc32c`), chosen at run time when the CPU has it, and a portable table
// (slicing-by-8) otherwise. Pure: no I/O, no threads; the choice is made once, on first use.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace ajar::protocol {

enum class Crc32cPath : std::uint8_t {
  kTable = 0,  // portable, any CPU
  kSse42 = 1,  // x86-64 with SSE4.2
  kArmv8 = 2,  // arm64 with the CRC32 extension
};

std::string_view to_string(Crc32cPath path) noexcept;  // "table", "sse4.2", "armv8"

// Whether this build and this CPU can run `path` (kTable: always).
bool crc32c_available(Crc32cPath path) noexcept;
// The path in use: the fastest available one unless a test forced another.
Crc32cPath crc32c_path() noexcept;
// Tests and benchmarks only: use `path` from now on (process-wide, not thread-safe against
// concurrent CRC calls). Returns false (and changes nothing) when it is not available.
bool force_crc32c_path(Crc32cPath path) noexcept;

// The raw register, for CRCs over several pieces: start with kCrc32cInit, feed the pieces in
// order through crc32c_update(), finish with crc32c_finish(). crc32c() does all three.
inline constexpr std::uint32_t kCrc32cInit = 0xFFFFFFFFu;
std::uint32_t crc32c_update(std::uint32_t crc, const std::uint8_t* data, std::size_t size) noexcept;
constexpr std::uint32_t crc32c_finish(std::uint32_t crc) noexcept {
  return crc ^ 0xFFFFFFFFu;
}
// One piece through one given path (crc32c_available(path) must hold), for tests and benchmarks.
std::uint32_t crc32c_update_with(Crc32cPath path, std::uint32_t crc, const std::uint8_t* data,
                                 std::size_t size) noexcept;

// CRC-32C of `bytes`, as used in frames. Check value: crc32c("123456789") == 0xE3069283.
std::uint32_t crc32c(std::span<const std::uint8_t> bytes) noexcept;

}  // namespace ajar::protocol
