// The decoder's fast path reads a payload without a bounds check per field once its length is the
// layout's (protocol/src/walk.hpp, payload_size()): a length computed wrong would read past the
// payload or refuse a good one. This holds payload_size() to what encode() writes and to the field
// list payload_layout() gives, for every sample in every minor version that has it, and to the
// size fields' refusals. White box: it includes the internal header.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <span>
#include <variant>

#include "../../protocol/src/walk.hpp"
#include "ajar/protocol/codec.hpp"
#include "ajar/protocol/layout.hpp"
#include "samples.hpp"

namespace ajar::protocol {
namespace {

std::size_t size_of_payload(const Message& m, std::span<const std::uint8_t> payload,
                            std::uint8_t minor) {
  return std::visit(
      [&]<typename T>(const T&) {
        return detail::payload_size<T>(payload.data(), payload.size(), minor);
      },
      m);
}

TEST(PayloadSize, IsWhatEncodeWritesForEverySampleInEveryMinor) {
  int checked = 0;
  for (const auto& s : samples::all()) {
    const Message& m = s.envelope.message;
    for (std::uint8_t minor = 0; minor <= kVersionMinor; ++minor) {
      std::array<std::uint8_t, kMaxFrameSize> frame{};
      const std::size_t n = encode(s.envelope, frame, minor);
      if (n == 0) continue;  // the type (or the Ack's type) is newer than `minor`
      const auto payload =
          std::span<const std::uint8_t>(frame).subspan(kHeaderSize, n - kHeaderSize);
      EXPECT_EQ(size_of_payload(m, payload, minor), payload.size()) << s.name << " 1." << +minor;
      std::size_t listed = 0;
      for (const FieldLayout& f : payload_layout(m, minor))
        listed = f.offset + f.size;
      EXPECT_EQ(listed, payload.size()) << s.name << " 1." << +minor;
      ++checked;
    }
  }
  EXPECT_GT(checked, 40);
}

TEST(PayloadSize, SizeFieldsMissingOrInvalidGiveNoSize) {
  const std::array<std::uint8_t, 3> empty{};
  // MeasureDoorPlane: count first, 3..16.
  EXPECT_EQ(detail::payload_size<MeasureDoorPlane>(empty.data(), 0, kVersionMinor),
            detail::kNoSize);
  for (const int count : {0, 2, 17, 255}) {
    const std::array<std::uint8_t, 1> p{static_cast<std::uint8_t>(count)};
    EXPECT_EQ(detail::payload_size<MeasureDoorPlane>(p.data(), p.size(), kVersionMinor),
              detail::kNoSize)
        << count;
  }
  const std::array<std::uint8_t, 1> three{3};
  EXPECT_EQ(detail::payload_size<MeasureDoorPlane>(three.data(), three.size(), kVersionMinor),
            1u + 3u * 25u);
  // Ack: acknowledged first, a request type of the frame's minor.
  EXPECT_EQ(detail::payload_size<Ack>(empty.data(), 1, kVersionMinor), detail::kNoSize);
  const std::array<std::uint8_t, 2> pong{0x02, 0x02};  // a daemon -> host type
  EXPECT_EQ(detail::payload_size<Ack>(pong.data(), pong.size(), kVersionMinor), detail::kNoSize);
  const std::array<std::uint8_t, 2> approach{0x23, 0x01};  // 1.1
  EXPECT_EQ(detail::payload_size<Ack>(approach.data(), approach.size(), 0), detail::kNoSize);
  EXPECT_EQ(detail::payload_size<Ack>(approach.data(), approach.size(), 1), 3u + 32u);
  const std::array<std::uint8_t, 2> stop{0x30, 0x01};
  EXPECT_EQ(detail::payload_size<Ack>(stop.data(), stop.size(), 0), 3u);
}

}  // namespace
}  // namespace ajar::protocol
