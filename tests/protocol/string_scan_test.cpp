// The string fields' scan (protocol/src/field_io.hpp, copy_and_scan_string): sixteen bytes at a
// time, split by each byte's index against the length, the last chunk overlapping the one before
// when the capacity is not a multiple of sixteen. Held here to a byte-by-byte reading of its
// contract for every capacity the messages use, every length 0..N + 1 and 255 (a length above the
// capacity makes every byte a string byte), every byte value at every place; the copy is the N
// bytes, and nothing outside them is read (the bytes sit alone in an allocation of exactly N: the
// sanitizer builds catch a read beyond). White box: it includes the internal header.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include "../../protocol/src/field_io.hpp"

namespace ajar::protocol {
namespace {

struct Expected {
  bool padding_zero = true;
  bool plain_ascii = true;
};

Expected by_bytes(const std::uint8_t* p, std::size_t capacity, std::size_t n) {
  Expected e;
  for (std::size_t i = 0; i < capacity; ++i) {
    if (i < n) {
      e.plain_ascii = e.plain_ascii && p[i] >= 0x20 && p[i] <= 0x7E;
    } else {
      e.padding_zero = e.padding_zero && p[i] == 0;
    }
  }
  return e;
}

// Every length 0..N + 1 and 255; at every place i, each of `values` in a string of `fill` bytes
// (then zero padding). `fill` is printable, so the verdict changes with the one byte only.
template <std::size_t N>
void expect_scan_as_the_rule(const std::vector<std::uint8_t>& values, std::uint8_t fill) {
  const auto bytes = std::make_unique<std::uint8_t[]>(N);  // exactly N: nothing after them
  std::array<char, N> copy{};
  std::size_t refused = 0;
  std::vector<std::size_t> lengths;
  for (std::size_t n = 0; n <= N + 1; ++n)
    lengths.push_back(n);
  lengths.push_back(255);
  for (const std::size_t n : lengths) {
    for (std::size_t i = 0; i < N; ++i) {
      for (const std::uint8_t value : values) {
        for (std::size_t k = 0; k < N; ++k)
          bytes[k] = k < n ? fill : std::uint8_t{0};
        bytes[i] = value;
        copy.fill('\x5A');
        const detail::StringScan got =
            detail::copy_and_scan_string<N>(bytes.get(), static_cast<std::uint8_t>(n), copy.data());
        const Expected want = by_bytes(bytes.get(), N, n);
        ASSERT_EQ(got.padding_zero, want.padding_zero)
            << "capacity " << N << " length " << n << " byte " << i << " value " << int{value};
        ASSERT_EQ(got.plain_ascii, want.plain_ascii)
            << "capacity " << N << " length " << n << " byte " << i << " value " << int{value};
        ASSERT_EQ(std::memcmp(copy.data(), bytes.get(), N), 0)
            << "capacity " << N << " length " << n << " byte " << i;
        if (!got.padding_zero || !got.plain_ascii) ++refused;
      }
    }
  }
  EXPECT_GT(refused, 0u);  // the byte values given do fail it
}

std::vector<std::uint8_t> every_byte() {
  std::vector<std::uint8_t> v(256);
  for (std::size_t b = 0; b < v.size(); ++b)
    v[b] = static_cast<std::uint8_t>(b);
  return v;
}

TEST(StringScan, EveryByteAtEveryPlaceOfEveryLengthIsJudgedAsByteByByte) {
  // The capacities of the messages: 32 and 48 are whole chunks, 120 and 200 end with an
  // overlapping one.
  expect_scan_as_the_rule<32>(every_byte(), 'a');
  expect_scan_as_the_rule<48>(every_byte(), '~');
  // The edges of printable ASCII, a UTF-8 lead byte, the top bit.
  const std::vector<std::uint8_t> edges{0x00, 0x01, 0x1F, 0x20, 0x61, 0x7E, 0x7F, 0x80, 0xC3, 0xFF};
  expect_scan_as_the_rule<120>(edges, ' ');
  expect_scan_as_the_rule<200>(edges, 'Q');
}

TEST(StringScan, AStringOfNonAsciiBytesWithZeroPaddingIsNotPlainButPadded) {
  // UTF-8 ("é" twice) then zeros: the padding passes, the string goes to the UTF-8 check.
  std::array<std::uint8_t, 48> b{0xC3, 0xA9, 0xC3, 0xA9};
  std::array<char, 48> copy{};
  const detail::StringScan s = detail::copy_and_scan_string<48>(b.data(), 4, copy.data());
  EXPECT_TRUE(s.padding_zero);
  EXPECT_FALSE(s.plain_ascii);
  // A zero byte inside the string is a control character, not padding.
  b = {'a', 0, 'b'};
  const detail::StringScan z = detail::copy_and_scan_string<48>(b.data(), 3, copy.data());
  EXPECT_TRUE(z.padding_zero);
  EXPECT_FALSE(z.plain_ascii);
  // Non-ASCII bytes after the length are padding that is not zero.
  b = {'a', 'b', 0xC3, 0xA9};
  const detail::StringScan p = detail::copy_and_scan_string<48>(b.data(), 2, copy.data());
  EXPECT_FALSE(p.padding_zero);
  EXPECT_TRUE(p.plain_ascii);
}

}  // namespace
}  // namespace ajar::protocol
