// Fuzzes decode_frame() (every message decoder is reached through the type field) and checks the
// round-trip property: a frame that decodes re-encodes to a frame that decodes to the same value,
// in the frame's own layout (a 1.0 frame as 1.0, a 1.1 frame as 1.1), and (for a minor this
// library speaks) to the same bytes apart from the CRC, which this build does not check.
#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>

#include "ajar/protocol/codec.hpp"

using namespace ajar::protocol;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> frame(data, size);
  if (size >= kHeaderSize) {
    (void)decode_header(frame.first<kHeaderSize>());
  }
  const auto out = decode_frame(frame);
  if (out.kind == StreamDecoder::Kind::kNeedMore) std::abort();
  if (out.kind == StreamDecoder::Kind::kError) {
    if (out.error.code == ajar::ErrorCode::kOk || out.error.field == nullptr) std::abort();
    return 0;
  }
  std::array<std::uint8_t, kMaxFrameSize> again{};
  const std::uint8_t minor = data[5] < kVersionMinor ? data[5] : kVersionMinor;
  const std::size_t n = encode(out.envelope, again, minor);
  if (n == 0) std::abort();  // everything that decodes must encode
  const auto second = decode_frame(std::span(again.data(), n));
  if (second.kind != StreamDecoder::Kind::kMessage) std::abort();
  if (second.envelope.request_id != out.envelope.request_id ||
      second.envelope.flags != out.envelope.flags ||
      !wire_equal(second.envelope.message, out.envelope.message)) {
    std::abort();
  }
  if (data[5] <= kVersionMinor) {  // a minor we speak: canonical, byte-exact apart from the CRC
    if (n != size || std::memcmp(again.data(), data, 18) != 0 ||
        std::memcmp(again.data() + kHeaderSize, data + kHeaderSize, n - kHeaderSize) != 0) {
      std::abort();
    }
  }
  return 0;
}
