// Frames: encode a message into bytes, and a streaming decoder that takes bytes in any chunking.
// Frame layout (little-endian, see docs/protocol.md): magic, version, type, flags, request id,
// payload length, CRC-32C over header and payload.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/core/error.hpp"
#include "ajar/protocol/crc32c.hpp"  // crc32c(), the frame checksum
#include "ajar/protocol/messages.hpp"

namespace ajar::protocol {

inline constexpr std::uint32_t kMagic = 0x52414A41;  // bytes "AJAR" on the wire
inline constexpr std::size_t kHeaderSize = 22;
inline constexpr std::size_t kMaxPayloadSize = 1024;  // hard maximum, checked before reading
inline constexpr std::size_t kMaxFrameSize = kHeaderSize + kMaxPayloadSize;

// Where each header field starts (docs/protocol.md section 2, tested against it); the payload
// starts at kHeaderSize. The codec, the conformance suite and the tests address header bytes only
// through these.
inline constexpr std::size_t kOffsetMagic = 0;           // u32, kMagic
inline constexpr std::size_t kOffsetVersionMajor = 4;    // u8
inline constexpr std::size_t kOffsetVersionMinor = 5;    // u8
inline constexpr std::size_t kOffsetType = 6;            // u16, MessageType
inline constexpr std::size_t kOffsetFlags = 8;           // u16, Flags
inline constexpr std::size_t kOffsetRequestId = 10;      // u32
inline constexpr std::size_t kOffsetPayloadLength = 14;  // u32
inline constexpr std::size_t kOffsetCrc = 18;  // u32, CRC-32C of bytes 0..kOffsetCrc-1 + payload
struct HeaderField {
  std::string_view name;  // as in docs/protocol.md
  std::size_t offset;
  std::size_t size;
};
inline constexpr std::array<HeaderField, 8> kHeaderFields{
    {{"magic", kOffsetMagic, 4},
     {"version_major", kOffsetVersionMajor, 1},
     {"version_minor", kOffsetVersionMinor, 1},
     {"type", kOffsetType, 2},
     {"flags", kOffsetFlags, 2},
     {"request_id", kOffsetRequestId, 4},
     {"payload_length", kOffsetPayloadLength, 4},
     {"crc", kOffsetCrc, 4}}};
static_assert(kOffsetCrc + 4 == kHeaderSize);

// Flag bits. Flags are must-understand: a frame with a reserved bit set is refused as a whole with
// kUnknownFlags (framing_lost false; the message is NOT processed; the session continues).
enum Flags : std::uint16_t {
  kFlagNone = 0,
  kFlagRetransmit = 1u << 0,  // host: this is a retry of an earlier request id (informational)
  kFlagKnownMask = kFlagRetransmit,
};

struct Envelope {
  std::uint32_t request_id = 0;  // replies echo the request's id; daemon-initiated frames use 0
  std::uint16_t flags = 0;
  Message message;
};

struct FrameHeader {
  std::uint32_t magic = kMagic;
  std::uint8_t version_major = kVersionMajor;
  std::uint8_t version_minor = kVersionMinor;
  std::uint16_t type = 0;  // raw MessageType
  std::uint16_t flags = 0;
  std::uint32_t request_id = 0;
  std::uint32_t payload_length = 0;
  std::uint32_t crc = 0;
};

// Encodes `envelope` as one frame into `out` (which must hold kMaxFrameSize bytes at most needed),
// in the layout of protocol 1.`minor` (0..kVersionMinor; the header carries 1.`minor`): a peer
// that said Hello with an older minor is answered in its own layout (docs/protocol.md section 7).
// Returns the frame size in bytes, or 0 when `out` is too small or the message cannot be encoded:
// a type (or an Ack of a type) that `minor` does not have, an Ack whose body alternative does not
// match `acknowledged` (or acknowledges a non-request type), a MeasureDoorPlane whose count is
// outside 3..16. Never allocates. Values are not validated otherwise: a sender must not put
// NaN/infinity in numeric fields (the peer's decoder refuses the frame).
std::size_t encode(const Envelope& envelope, std::span<std::uint8_t> out,
                   std::uint8_t minor = kVersionMinor) noexcept;
// Convenience: appends one frame to `out`. Returns false (and leaves `out` unchanged) when the
// message cannot be encoded (see encode()).
bool encode_append(const Envelope& envelope, std::vector<std::uint8_t>& out,
                   std::uint8_t minor = kVersionMinor);

// True when the two messages are of the same type and encode to the same payload bytes (doubles
// compared bit for bit). Used by tests, the fuzzer and conformance checks.
bool wire_equal(const Message& a, const Message& b) noexcept;

// A decoding failure: what was wrong, where, and whether the byte stream can continue.
// framing_lost is true for kBadMagic, kUnsupportedVersion and kPayloadTooLarge (and for a
// decode_frame() input that is not exactly one frame); every other error skips exactly the one
// frame (its declared length) and the stream continues with the next frame.
// Order of checks: magic, major version, payload length maximum, CRC, flags, type, then the
// payload: the fields that size it (Ack.acknowledged, MeasureDoorPlane.count), the payload length
// for the type, then every other field in wire order; the first failure is reported.
// Layouts follow the frame's minor version: a 1.0 frame has the 1.0 length (fields appended by
// 1.1 keep their defaults) and may not carry a type 1.1 added (UNKNOWN_MESSAGE_TYPE). A frame whose
// minor version is newer than kVersionMinor may carry a longer payload (fields appended by the
// newer minor): the extra bytes are ignored. Otherwise the length must be exact.
struct DecodeError {
  ErrorCode code = ErrorCode::kOk;
  std::uint32_t request_id = 0;  // from the header when it was readable, else 0
  std::uint16_t type = 0;        // raw message type from the header when readable, else 0
  bool framing_lost = false;     // true: the connection must be closed (bad magic, oversize)
  const char* field = "";        // offending field, e.g. "points[2].z", "frame", "header.crc"
  // For the sentence (describe()): the frame's minor version, the offending raw value (enum byte,
  // count, length, flags, type, the number's bit pattern, string length) and what was allowed
  // (enum value count, maximum, expected length, computed CRC, string capacity), and a reason.
  std::uint8_t version_minor = 0;
  std::uint64_t value = 0;
  std::uint64_t limit = 0;
  const char* reason = "";
};

// One sentence for the operator saying which field was wrong and why, e.g. "p2.z is NaN: numbers
// on the wire must be finite" or "header.payload_length is 40: Status in protocol 1.0 has 286
// bytes". At most 200 bytes (fits ErrorReply::message).
std::string describe(const DecodeError& error);

// Streaming decoder. Feed it bytes as they arrive, in any chunking (one byte at a time works);
// it yields one outcome at a time. A frame that arrives whole in one call is decoded where it is;
// a frame split across calls is gathered in a buffer of kMaxFrameSize that the decoder allocates
// at the first such frame and keeps: no allocation per frame, and none at all for a peer whose
// frames always arrive whole (most sessions: 257 of them hold 0.27 MiB less, docs/performance.md).
// If that one allocation fails, feed() yields kInternal with framing_lost (reason "out of
// memory"): the stream cannot continue.
class StreamDecoder {
 public:
  enum class Kind { kNeedMore, kMessage, kError };
  struct Outcome {
    Kind kind = Kind::kNeedMore;
    Envelope envelope;  // valid when kind == kMessage
    DecodeError error;  // valid when kind == kError
  };

  // Consumes bytes from `in` until one outcome is produced or `in` is exhausted; returns the number
  // of bytes consumed. Call again with the rest of `in` while it is non-empty. After an error with
  // framing_lost the decoder stays failed (every later call consumes all of `in` and yields the
  // same error) until reset(). Bad magic is detected at the first wrong byte.
  std::size_t feed(std::span<const std::uint8_t> in, Outcome& outcome) noexcept;
  // Forgets the frame being gathered and a failure; keeps the buffer if there is one.
  void reset() noexcept;
  // The bytes this decoder holds beyond itself: 0 until a frame arrives split across calls, then
  // kMaxFrameSize.
  std::size_t buffer_bytes() const noexcept { return buffer_ ? kMaxFrameSize : 0; }

 private:
  using Buffer = std::array<std::uint8_t, kMaxFrameSize>;
  // feed() of what is not a whole frame with a good header at the start of `in`: a failed decoder,
  // a frame split across calls, a wrong header (found at its first wrong byte).
  std::size_t feed_bytewise(std::span<const std::uint8_t> in, Outcome& outcome) noexcept;
  std::unique_ptr<Buffer> buffer_;  // not zeroed: only [0, filled_) is read
  std::size_t filled_ = 0;
  bool failed_ = false;
  DecodeError failure_;
};

// Decodes one complete frame (header + payload) held in `frame`. Used by the streaming decoder and
// directly by tests and the fuzzer.
StreamDecoder::Outcome decode_frame(std::span<const std::uint8_t> frame) noexcept;

// Decodes a header only (first kHeaderSize bytes); no CRC check.
FrameHeader decode_header(std::span<const std::uint8_t, kHeaderSize> bytes) noexcept;

}  // namespace ajar::protocol
