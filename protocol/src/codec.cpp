// Frames: the header, the CRC, encode() and the decoders. The payloads are written and read by
// walking the message tables (message_schema.hpp) with the Writer and the Reader (field_io.hpp).
#include "ajar/protocol/codec.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <new>
#include <type_traits>

#include "ajar/protocol/crc32c.hpp"
#include "field_io.hpp"
#include "little_endian.hpp"
#include "walk.hpp"

namespace ajar::protocol {

using namespace detail;

namespace {

constexpr std::array<std::uint8_t, 4> kMagicBytes = {0x41, 0x4A, 0x41, 0x52};  // "AJAR"

// The checked Reader's walk of a payload into `t` (decode_as<T>: a payload the FastReader refused,
// or one whose length is not its layout's), out of line: decode_as<T>'s fast path then saves
// fewer registers. `fast`: the FastReader refused it (the fuzzers' build checks it was right to).
template <typename T>
[[gnu::noinline]] bool decode_with_reader(const std::uint8_t* p, std::size_t size,
                                          std::uint8_t minor, bool newer,
                                          [[maybe_unused]] bool fast, T& t,
                                          DecodeError& e) noexcept {
  Reader r(std::span(p, size), minor);
  walk<Text("")>(r, t);
  const bool decoded = r.finish(newer, e);
#ifdef AJAR_PROTOCOL_FUZZING
  if (fast && decoded) std::abort();  // the fast path refused what the checked walk accepts
#endif
  return decoded;
}

// One function per message type (the walk inlined into it), like hand-written field code: decodes
// the payload p[0, size) of a frame of protocol 1.`wire_minor` into `m`. False: the payload is
// refused, and e's code, field, value, limit and reason say why (checks 7-9 of docs/protocol.md
// section 3). A payload whose length is its layout's (payload_size()) is read by the FastReader
// in one pass; anything it refuses, and any other length, goes to the checked Reader, which finds
// and describes the first failure in wire order.
template <typename T>
[[gnu::noinline]] bool decode_as(const std::uint8_t* p, std::size_t size, std::uint8_t wire_minor,
                                 Message& m, DecodeError& e) noexcept {
  // The layout is the frame's minor version's (a newer minor: ours, extra bytes ignored).
  const std::uint8_t minor = std::min(wire_minor, kVersionMinor);
  const bool newer = wire_minor > kVersionMinor;
  // Reuse the alternative when it is already there (a stream of Telemetry, say): every field is
  // overwritten. MeasureDoorPlane starts fresh so that points beyond `count` are default, and so
  // does an older layout (the fields it lacks keep their defaults).
  T* t = std::get_if<T>(&m);
  if (std::is_same_v<T, MeasureDoorPlane> || t == nullptr || minor < kVersionMinor) {
    t = &m.template emplace<T>();
  }
  const std::size_t layout = payload_size<T>(p, size, minor);
  const bool fast = layout == size || (newer && layout != kNoSize && layout < size);
  if (fast) {
    FastReader r(p, minor);
    walk<Text("")>(r, *t);
    if (r.ok()) {
#ifdef AJAR_PROTOCOL_FUZZING
      // The fuzzers hold the fast path to the checked one: the same verdict, the same value.
      Message checked{std::in_place_type<T>};
      Reader c(std::span(p, size), minor);
      walk<Text("")>(c, std::get<T>(checked));
      DecodeError ce;
      if (!c.finish(newer, ce) || !wire_equal(checked, m)) std::abort();
#endif
      return true;
    }
  }
  return decode_with_reader(p, size, minor, newer, fast, *t, e);
}

template <typename T>
[[gnu::noinline]] void encode_as(Writer& w, const T& m) noexcept {
  walk<Text("")>(w, m);
}

// decode_as<T> of every Message alternative, by row of the message table.
constexpr auto kDecoders = []<std::size_t... I>(std::index_sequence<I...>) {
  return std::array<bool (*)(const std::uint8_t*, std::size_t, std::uint8_t, Message&,
                             DecodeError&) noexcept,
                    sizeof...(I)>{&decode_as<std::variant_alternative_t<I, Message>>...};
}
(std::make_index_sequence<std::variant_size_v<Message>>{});

// Encodes the payload of `m` into `out`; returns its size, or nullopt-like 0 with ok=false.
bool encode_payload(const Message& m, std::span<std::uint8_t> out, std::size_t& size,
                    std::uint8_t minor = kVersionMinor) noexcept {
  Writer w(out.data(), std::min(out.size(), kMaxPayloadSize), minor);
  std::visit([&w](const auto& v) { encode_as(w, v); }, m);
  size = w.size();
  return w.ok();
}

// Checks of the first header bytes that decide whether the stream can continue.
bool check_header(const std::uint8_t* h, DecodeError& e) noexcept {
  e = DecodeError{};
  if (std::memcmp(h + kOffsetMagic, kMagicBytes.data(), kMagicBytes.size()) != 0) {
    e.code = ErrorCode::kBadMagic;
    e.framing_lost = true;
    e.field = "header.magic";
    return false;
  }
  e.type = get_u16(h + kOffsetType);
  e.request_id = get_u32(h + kOffsetRequestId);
  e.version_minor = h[kOffsetVersionMinor];
  if (h[kOffsetVersionMajor] != kVersionMajor) {
    e.code = ErrorCode::kUnsupportedVersion;
    e.framing_lost = true;
    e.field = "header.version_major";
    e.value = h[kOffsetVersionMajor];
    return false;
  }
  const std::uint32_t length = get_u32(h + kOffsetPayloadLength);
  if (length > kMaxPayloadSize) {
    e.code = ErrorCode::kPayloadTooLarge;
    e.framing_lost = true;
    e.field = "header.payload_length";
    e.value = length;
    e.limit = kMaxPayloadSize;
    return false;
  }
  return true;
}

std::uint32_t frame_crc(const std::uint8_t* header,
                        std::span<const std::uint8_t> payload) noexcept {
  const std::uint32_t crc = crc32c_update(kCrc32cInit, header, kOffsetCrc);
  return crc32c_finish(crc32c_update(crc, payload.data(), payload.size()));
}

// kRowOfType with check 6 made: by minor version 0..kVersionMinor, the row of each type when
// protocol 1.`minor` has it, else kNoRow (one load per frame instead of the row and its `since`).
constexpr auto kRowOfTypeInMinor = [] {
  std::array<std::array<std::uint8_t, kRowOfType.size()>, kVersionMinor + 1> rows{};
  for (std::size_t minor = 0; minor <= kVersionMinor; ++minor) {
    for (std::size_t i = 0; i < kRowOfType.size(); ++i) {
      const std::uint8_t row = kRowOfType[i];
      rows[minor][i] = row == kNoRow || kMessageTable[row].since > minor ? kNoRow : row;
    }
  }
  return rows;
}();

// The row of `type` in the message table when protocol 1.`minor` has it (check 6), else kNoRow;
// a minor above kVersionMinor is taken as kVersionMinor.
std::size_t row_of(std::uint16_t type, std::uint8_t minor) noexcept {
  const std::size_t i = static_cast<std::size_t>(type) - kLowestType;  // wraps below the lowest
  const std::size_t m = std::min<std::size_t>(minor, kRowOfTypeInMinor.size() - 1);
  return i < kRowOfType.size() ? kRowOfTypeInMinor[m][i] : kNoRow;
}

// The error of a frame whose header passed checks 1-3: checks 4-6 in order when `payload_refused`
// is false (one of them failed), else the payload's error that the decoder has put in out.error;
// then the header's request id, type and minor version. Out of the way of the frames that decode.
[[gnu::cold, gnu::noinline]] void frame_error(const std::uint8_t* h,
                                              [[maybe_unused]] std::uint32_t length,
                                              bool payload_refused,
                                              StreamDecoder::Outcome& out) noexcept {
  DecodeError& e = out.error;
  out.kind = StreamDecoder::Kind::kError;
  if (!payload_refused) {
    e = DecodeError{};
    const std::uint16_t flags = get_u16(h + kOffsetFlags);
#ifndef AJAR_PROTOCOL_FUZZING
    const std::uint32_t crc = frame_crc(h, std::span(h + kHeaderSize, length));
#else
    const std::uint32_t crc = get_u32(h + kOffsetCrc);
#endif
    if (crc != get_u32(h + kOffsetCrc)) {
      e.code = ErrorCode::kCrcMismatch;
      e.field = "header.crc";
      e.value = get_u32(h + kOffsetCrc);
      e.limit = crc;
    } else if ((flags & ~static_cast<std::uint16_t>(kFlagKnownMask)) != 0) {
      e.code = ErrorCode::kUnknownFlags;
      e.field = "header.flags";
      e.value = flags;
      e.limit = kFlagKnownMask;
    } else {
      e.code = ErrorCode::kUnknownMessageType;
      e.field = refusal_field::kHeaderType.data();  // a literal: zero terminated
      e.value = get_u16(h + kOffsetType);
    }
  }
  e.framing_lost = false;
  e.type = get_u16(h + kOffsetType);
  e.request_id = get_u32(h + kOffsetRequestId);
  e.version_minor = h[kOffsetVersionMinor];
}

// Checks 4-9 of a frame whose header passed checks 1-3 and whose payload (its length from the
// header) follows it in memory; decodes it into `out` (reusing its storage). The header is read
// once, every check is made, and the error record is written once: cleared for a message, filled
// for an error. Only the frame and the outcome are kept across the calls (the CRC's and the
// type's decoder): every header field is loaded where it is used. Inlined into its callers: in
// feed()'s whole-frame path it is the whole of the work, with no call of its own.
[[gnu::always_inline]] inline void decode_checked(const std::uint8_t* h,
                                                  StreamDecoder::Outcome& out) noexcept {
#ifndef AJAR_PROTOCOL_FUZZING
  // frame_crc()'s two pieces, the payload's length loaded after the header's piece: nothing but
  // the frame and the outcome is held across a call.
  const std::uint32_t header_crc = crc32c_update(kCrc32cInit, h, kOffsetCrc);
  const bool crc_ok =
      crc32c_finish(crc32c_update(header_crc, h + kHeaderSize,
                                  get_u32(h + kOffsetPayloadLength))) == get_u32(h + kOffsetCrc);
#else
  const bool crc_ok = true;  // the fuzzers' build skips the CRC comparison (tests/fuzz)
#endif
  const std::uint8_t wire_minor = h[kOffsetVersionMinor];
  const std::size_t row = row_of(get_u16(h + kOffsetType), wire_minor);
  const bool header_ok =
      crc_ok && (get_u16(h + kOffsetFlags) & ~static_cast<std::uint16_t>(kFlagKnownMask)) == 0 &&
      row != kNoRow;
  const std::uint32_t length = get_u32(h + kOffsetPayloadLength);
  if (header_ok &&
      kDecoders[row](h + kHeaderSize, length, wire_minor, out.envelope.message, out.error)) {
    out.kind = StreamDecoder::Kind::kMessage;
    out.envelope.request_id = get_u32(h + kOffsetRequestId);
    out.envelope.flags = get_u16(h + kOffsetFlags);
    // A record this decoder cleared or never filled has code kOk: clear only a filled one.
    if (out.error.code != ErrorCode::kOk) out.error = DecodeError{};
    return;
  }
  frame_error(h, get_u32(h + kOffsetPayloadLength), header_ok, out);
}

// Decodes one whole frame (exactly one: else kBadPayloadLength, framing lost) into `out`.
void decode_into(std::span<const std::uint8_t> frame, StreamDecoder::Outcome& out) noexcept {
  DecodeError& e = out.error;
  out.kind = StreamDecoder::Kind::kError;
  if (frame.size() < kHeaderSize) {
    e = DecodeError{};
    e.code = ErrorCode::kBadPayloadLength;
    e.framing_lost = true;
    e.field = "frame";
    return;
  }
  const std::uint8_t* h = frame.data();
  if (!check_header(h, e)) return;
  const std::uint32_t length = get_u32(h + kOffsetPayloadLength);
  if (frame.size() != kHeaderSize + length) {
    e.code = ErrorCode::kBadPayloadLength;
    e.framing_lost = true;
    e.field = "frame";
    return;
  }
  decode_checked(h, out);
}

}  // namespace

std::size_t encode(const Envelope& envelope, std::span<std::uint8_t> out,
                   std::uint8_t minor) noexcept {
  if (out.size() < kHeaderSize || minor > kVersionMinor) return 0;
  if (minor_of(type_of(envelope.message)) > minor) return 0;
  std::size_t length = 0;
  if (!encode_payload(envelope.message, out.subspan(kHeaderSize), length, minor)) return 0;
  std::uint8_t* h = out.data();
  std::memcpy(h + kOffsetMagic, kMagicBytes.data(), kMagicBytes.size());
  h[kOffsetVersionMajor] = kVersionMajor;
  h[kOffsetVersionMinor] = minor;
  put_u16(h + kOffsetType, static_cast<std::uint16_t>(type_of(envelope.message)));
  put_u16(h + kOffsetFlags, envelope.flags);
  put_u32(h + kOffsetRequestId, envelope.request_id);
  put_u32(h + kOffsetPayloadLength, static_cast<std::uint32_t>(length));
  put_u32(h + kOffsetCrc, frame_crc(h, out.subspan(kHeaderSize, length)));
  return kHeaderSize + length;
}

bool encode_append(const Envelope& envelope, std::vector<std::uint8_t>& out, std::uint8_t minor) {
  const std::size_t old = out.size();
  out.resize(old + kMaxFrameSize);
  const std::size_t n = encode(envelope, std::span(out).subspan(old), minor);
  out.resize(old + n);
  return n != 0;
}

bool wire_equal(const Message& a, const Message& b) noexcept {
  if (a.index() != b.index()) return false;
  std::array<std::uint8_t, kMaxPayloadSize> ba{}, bb{};
  std::size_t na = 0, nb = 0;
  const bool oka = encode_payload(a, ba, na);
  const bool okb = encode_payload(b, bb, nb);
  return oka && okb && na == nb && std::memcmp(ba.data(), bb.data(), na) == 0;
}

FrameHeader decode_header(std::span<const std::uint8_t, kHeaderSize> bytes) noexcept {
  const std::uint8_t* h = bytes.data();
  FrameHeader f;
  f.magic = get_u32(h + kOffsetMagic);
  f.version_major = h[kOffsetVersionMajor];
  f.version_minor = h[kOffsetVersionMinor];
  f.type = get_u16(h + kOffsetType);
  f.flags = get_u16(h + kOffsetFlags);
  f.request_id = get_u32(h + kOffsetRequestId);
  f.payload_length = get_u32(h + kOffsetPayloadLength);
  f.crc = get_u32(h + kOffsetCrc);
  return f;
}

StreamDecoder::Outcome decode_frame(std::span<const std::uint8_t> frame) noexcept {
  StreamDecoder::Outcome out;
  decode_into(frame, out);
  return out;
}

std::size_t StreamDecoder::feed(std::span<const std::uint8_t> in, Outcome& outcome) noexcept {
  // Fast path: a whole frame at the start of `in` whose header passes checks 1-3 is decoded in
  // place, without copying. Anything else (a frame split across calls, a wrong header) goes the
  // byte-wise way below, which finds and reports a wrong header at its first wrong byte.
  if (filled_ == 0 && !failed_ && in.size() >= kHeaderSize) {
    const std::uint8_t* h = in.data();
    const std::uint32_t length = get_u32(h + kOffsetPayloadLength);
    if (get_u32(h + kOffsetMagic) == kMagic && h[kOffsetVersionMajor] == kVersionMajor &&
        length <= kMaxPayloadSize && in.size() - kHeaderSize >= length) {
      decode_checked(h, outcome);
      return kHeaderSize + get_u32(h + kOffsetPayloadLength);  // loaded again: one register less
    }
  }
  return feed_bytewise(in, outcome);
}

// The rest of feed(), out of line: its fast path then saves one register and puts nothing on the
// stack.
[[gnu::noinline]] std::size_t StreamDecoder::feed_bytewise(std::span<const std::uint8_t> in,
                                                           Outcome& outcome) noexcept {
  outcome.kind = Kind::kNeedMore;
  if (failed_) {
    outcome.kind = Kind::kError;
    outcome.error = failure_;
    return in.size();
  }
  std::size_t used = 0;
  const auto fail = [&](const DecodeError& e) {
    failed_ = true;
    failure_ = e;
    outcome.kind = Kind::kError;
    outcome.error = e;
    return used;
  };
  if (in.empty()) return 0;
  // The frame is split across calls (or its header is wrong): it is gathered in the buffer,
  // allocated now if this is the decoder's first.
  if (!buffer_) {
    buffer_.reset(new (std::nothrow) Buffer);
    if (!buffer_) {
      used = in.size();
      DecodeError e;
      e.code = ErrorCode::kInternal;
      e.framing_lost = true;
      e.field = "frame";
      e.reason = "out of memory";
      return fail(e);
    }
  }
  std::uint8_t* const buffer = buffer_->data();
  if (filled_ < kHeaderSize) {
    const std::size_t n = std::min(kHeaderSize - filled_, in.size());
    if (n == 0) return 0;
    std::memcpy(buffer + filled_, in.data(), n);
    const std::size_t magic_end = std::min(filled_ + n, kMagicBytes.size());
    for (std::size_t i = filled_; i < magic_end; ++i) {
      if (buffer[i] != kMagicBytes[i]) {
        used = i - filled_ + 1;
        DecodeError e;
        e.code = ErrorCode::kBadMagic;
        e.framing_lost = true;
        e.field = "header.magic";
        return fail(e);
      }
    }
    filled_ += n;
    used = n;
    if (filled_ < kHeaderSize) return used;
    DecodeError e;
    if (!check_header(buffer, e)) return fail(e);
  }
  const std::size_t total = kHeaderSize + get_u32(buffer + kOffsetPayloadLength);
  const std::size_t n = std::min(total - filled_, in.size() - used);
  if (n > 0) std::memcpy(buffer + filled_, in.data() + used, n);
  filled_ += n;
  used += n;
  if (filled_ < total) return used;
  decode_checked(buffer, outcome);
  filled_ = 0;
  return used;
}

void StreamDecoder::reset() noexcept {
  filled_ = 0;
  failed_ = false;
  failure_ = DecodeError{};
}

}  // namespace ajar::protocol
