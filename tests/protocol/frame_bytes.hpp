// Codec tests' frame helpers: encode to bytes, and patch a frame (length, CRC) after a test edited
// its bytes, so that the decoder's later checks are reached.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "ajar/protocol/codec.hpp"

namespace ajar::protocol {

using Bytes = std::vector<std::uint8_t>;

inline Bytes encode_bytes(const Envelope& e, std::uint8_t minor = kVersionMinor) {
  Bytes out;
  EXPECT_TRUE(encode_append(e, out, minor));
  return out;
}

// Recomputes the CRC after a test patched a frame (the header before the CRC + payload).
inline void refresh_crc(Bytes& b) {
  Bytes covered(b.begin(), b.begin() + kOffsetCrc);
  covered.insert(covered.end(), b.begin() + kHeaderSize, b.end());
  const std::uint32_t crc = crc32c(covered);
  for (std::size_t i = 0; i < 4; ++i)
    b[kOffsetCrc + i] = static_cast<std::uint8_t>(crc >> (8 * i));
}
inline void set_length(Bytes& b) {
  const auto n = static_cast<std::uint32_t>(b.size() - kHeaderSize);
  for (std::size_t i = 0; i < 4; ++i)
    b[kOffsetPayloadLength + i] = static_cast<std::uint8_t>(n >> (8 * i));
  refresh_crc(b);
}

// The error a frame that must not decode decodes to.
inline DecodeError decode_error(const Bytes& b) {
  const auto out = decode_frame(b);
  EXPECT_EQ(out.kind, StreamDecoder::Kind::kError);
  return out.error;
}

}  // namespace ajar::protocol
