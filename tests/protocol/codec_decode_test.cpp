// Codec unit tests, the decoder's checks: header errors, sizes, minor versions, payload field
// errors naming the field, Ack bodies, unknown codes, string sanitising, message names.
#include <gtest/gtest.h>

// GCC 12 with -fsanitize=address reports -Wmaybe-uninitialized for inactive alternatives of
// std::variant temporaries (Ack{..., PlaneAck/EmptyAck}) built inline: a known false positive.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include <bit>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "ajar/protocol/codec.hpp"
#include "frame_bytes.hpp"
#include "samples.hpp"

namespace ajar::protocol {
namespace {

TEST(Decode, HeaderErrors) {
  const Bytes ping = encode_bytes(Envelope{0x55, 0, Ping{9}});
  Bytes b = ping;
  b[kOffsetMagic] = 'B';
  auto e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kBadMagic);
  EXPECT_TRUE(e.framing_lost);

  b = ping;
  b[kOffsetVersionMajor] = 0;
  refresh_crc(b);
  e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kUnsupportedVersion);
  EXPECT_TRUE(e.framing_lost);
  EXPECT_EQ(e.request_id, 0x55u);
  EXPECT_EQ(e.type, 0x0102);

  b = ping;
  b[kOffsetCrc + 2] ^= 0xFF;
  e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kCrcMismatch);
  EXPECT_FALSE(e.framing_lost);
  EXPECT_EQ(e.request_id, 0x55u);

  b = ping;
  b[kOffsetFlags + 1] = 0x40;  // flags 0x4000
  refresh_crc(b);
  e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kUnknownFlags);
  EXPECT_FALSE(e.framing_lost);

  b = ping;
  b[kOffsetFlags] = kFlagRetransmit;
  refresh_crc(b);
  const auto ok = decode_frame(b);
  ASSERT_EQ(ok.kind, StreamDecoder::Kind::kMessage);
  EXPECT_EQ(ok.envelope.flags, kFlagRetransmit);

  // Not exactly one frame.
  b = ping;
  b.push_back(0);
  e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kBadPayloadLength);
  EXPECT_TRUE(e.framing_lost);
  e = decode_error(Bytes(ping.begin(), ping.begin() + 10));
  EXPECT_TRUE(e.framing_lost);
}

TEST(Decode, MaximumPayloadIsAcceptedAsFramingButNotAsPing) {
  Bytes b = encode_bytes(Envelope{1, 0, Ping{}});
  b.resize(kHeaderSize + kMaxPayloadSize, 0);
  set_length(b);
  auto e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kBadPayloadLength);
  EXPECT_FALSE(e.framing_lost);
  b.push_back(0);
  set_length(b);
  e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kPayloadTooLarge);
  EXPECT_TRUE(e.framing_lost);
}

TEST(Decode, NewerMinorMayAppendButOlderMayNot) {
  Bytes b = encode_bytes(Envelope{1, 0, Ping{77}});
  b.push_back(0xAB);
  set_length(b);
  EXPECT_EQ(decode_error(b).code, ErrorCode::kBadPayloadLength);
  b[kOffsetVersionMinor] = kVersionMinor + 1;  // a newer minor
  refresh_crc(b);
  const auto out = decode_frame(b);
  ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage);
  EXPECT_EQ(std::get<Ping>(out.envelope.message).client_time_ns, 77u);
  // Even a newer minor must not shorten a payload.
  Bytes s = encode_bytes(Envelope{1, 0, Ping{77}});
  s.pop_back();
  s[kOffsetVersionMinor] = kVersionMinor + 1;
  set_length(s);
  EXPECT_EQ(decode_error(s).code, ErrorCode::kBadPayloadLength);
}

// A string field's checks (zero padding, then UTF-8 without control characters) judge every byte
// value at every place of every length as a byte-by-byte reading of the rule does (is_wire_string
// for the string, "all zero" for the padding): the decoder scans sixteen bytes at a time
// (field_io.hpp, copy_and_scan_string), whose edges are the chunk boundaries and the length.
template <typename Message, std::size_t N>
void expect_string_checks_as_the_rule(Message m, FixedString<N> Message::*field,
                                      const std::vector<std::uint8_t>& values) {
  (m.*field).assign(std::string(N, 'Q'));
  const Bytes whole = encode_bytes(Envelope{7, 0, m});
  std::size_t at = kHeaderSize;  // the field's length byte: the first of N + 1 bytes N, 'Q' ...
  while (!(whole[at] == N && whole[at + 1] == 'Q'))
    ++at;
  for (std::size_t n = 0; n <= N; ++n) {
    Bytes b = whole;
    b[at] = static_cast<std::uint8_t>(n);
    for (std::size_t i = 0; i < N; ++i)
      b[at + 1 + i] = i < n ? 'a' : 0;
    for (std::size_t i = 0; i < N; ++i) {
      for (const std::uint8_t value : values) {
        const std::uint8_t old = b[at + 1 + i];
        b[at + 1 + i] = value;
        refresh_crc(b);
        const auto out = decode_frame(b);
        b[at + 1 + i] = old;
        const std::string_view text(reinterpret_cast<const char*>(&b[at + 1]), n);
        std::string string(text);
        if (i < n) string[i] = static_cast<char>(value);
        const char* want = i >= n && value != 0      ? "non-zero padding"
                           : !is_wire_string(string) ? "invalid UTF-8 or a control character"
                                                     : nullptr;
        if (want == nullptr) {
          ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage)
              << "n " << n << " byte " << i << " value " << int{value};
        } else {
          ASSERT_EQ(out.kind, StreamDecoder::Kind::kError)
              << "n " << n << " byte " << i << " value " << int{value};
          EXPECT_EQ(out.error.code, ErrorCode::kBadString);
          ASSERT_STREQ(out.error.reason, want)
              << "n " << n << " byte " << i << " value " << int{value};
        }
      }
    }
  }
}

TEST(Decode, StringChecksJudgeEveryByteAtEveryPlaceOfEveryLengthAsTheRule) {
  std::vector<std::uint8_t> every(256);
  for (std::size_t v = 0; v < every.size(); ++v)
    every[v] = static_cast<std::uint8_t>(v);
  expect_string_checks_as_the_rule(FetchRecording{}, &FetchRecording::name, every);  // 48 bytes
  // 200 bytes: the edges of printable ASCII, a lead byte, the top bit.
  expect_string_checks_as_the_rule(ErrorReply{}, &ErrorReply::message,
                                   {0x00, 0x01, 0x1F, 0x20, 0x61, 0x7E, 0x7F, 0x80, 0xC3, 0xFF});
}

TEST(Decode, PayloadFieldErrorsNameTheField) {
  // MeasureDoorWidth: p1 at payload offset 0, p2 at 25; each: frame u8, x, y, z f64.
  const Bytes width = encode_bytes(Envelope{3, 0, samples::all()[5].envelope.message});
  ASSERT_EQ(width.size(), kHeaderSize + 50);
  Bytes b = width;
  b[kHeaderSize + 25] = 2;
  refresh_crc(b);
  auto e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kInvalidEnumValue);
  EXPECT_STREQ(e.field, "p2.frame");
  EXPECT_EQ(e.request_id, 3u);

  b = width;
  const auto inf = std::bit_cast<std::uint64_t>(-std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < 8; ++i)
    b[kHeaderSize + 1 + 8 + i] = static_cast<std::uint8_t>(inf >> (8 * i));
  refresh_crc(b);
  e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kNonFiniteNumber);
  EXPECT_STREQ(e.field, "p1.y");

  // The first failing field in wire order wins.
  b[kHeaderSize + 25] = 9;
  refresh_crc(b);
  EXPECT_STREQ(decode_error(b).field, "p1.y");

  // A length error wins over field errors (apart from the fields that size the payload).
  b.pop_back();
  set_length(b);
  EXPECT_EQ(decode_error(b).code, ErrorCode::kBadPayloadLength);
}

TEST(Decode, PlanePointFieldNames) {
  MeasureDoorPlane plane;
  plane.count = 16;
  const Bytes good = encode_bytes(Envelope{1, 0, plane});
  for (std::size_t i : {0u, 9u, 10u, 15u}) {
    Bytes b = good;
    const auto nan = std::bit_cast<std::uint64_t>(std::numeric_limits<double>::quiet_NaN());
    for (std::size_t k = 0; k < 8; ++k) {
      b[kHeaderSize + 1 + 25 * i + 17 + k] = static_cast<std::uint8_t>(nan >> (8 * k));
    }
    refresh_crc(b);
    const auto e = decode_error(b);
    EXPECT_EQ(e.code, ErrorCode::kNonFiniteNumber);
    EXPECT_EQ(std::string(e.field), "points[" + std::to_string(i) + "].z");
  }
}

TEST(Decode, AckBodyFollowsAcknowledged) {
  // An Ack for MeasureHandle must carry a span body: 3 + 57 bytes.
  Bytes b =
      encode_bytes(Envelope{4, 0, Ack{MessageType::kMeasureHandle, {}, samples::handle_ack()}});
  ASSERT_EQ(b.size(), kHeaderSize + 60);
  // Claiming it acknowledges AlignBase (empty body) makes the length wrong.
  b[kHeaderSize] = 0x20;
  b[kHeaderSize + 1] = 0x01;
  refresh_crc(b);
  EXPECT_EQ(decode_error(b).code, ErrorCode::kBadPayloadLength);
  // Acknowledging an unknown type is an invalid enum, reported before the length.
  b[kHeaderSize] = 0x99;
  refresh_crc(b);
  const auto e = decode_error(b);
  EXPECT_EQ(e.code, ErrorCode::kInvalidEnumValue);
  EXPECT_STREQ(e.field, "acknowledged");
}

TEST(Decode, UnknownErrorCodesPassThrough) {
  // Error codes are not validated: a newer daemon may send codes this version does not know.
  ErrorReply r;
  r.code = static_cast<ErrorCode>(777);
  r.offending_type = static_cast<MessageType>(0x0777);
  const auto out = decode_frame(encode_bytes(Envelope{1, 0, r}));
  ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage);
  EXPECT_EQ(static_cast<int>(std::get<ErrorReply>(out.envelope.message).code), 777);
}

TEST(Strings, AssignSanitizes) {
  FixedString<8> s("abc\ndef");
  EXPECT_EQ(s.view(), "abc def");
  s.assign("ab\xff");
  EXPECT_EQ(s.view(), "ab?");
  // Truncation never cuts a UTF-8 sequence: 7 ASCII + a 2-byte character does not fit in 8.
  s.assign("1234567\xc3\xbc");
  EXPECT_EQ(s.view(), "1234567");
  s.assign("123456\xc3\xbc");
  EXPECT_EQ(s.view(), "123456\xc3\xbc");
  EXPECT_TRUE(is_wire_string("T\xc3\xbcr"));
  EXPECT_FALSE(is_wire_string("a\x7f"));
  EXPECT_FALSE(is_wire_string("\xed\xa0\x80"));  // surrogate
  EXPECT_FALSE(is_wire_string("\xc0\xaf"));      // overlong
  EXPECT_FALSE(is_wire_string(std::string_view("a\0b", 3)));
}

TEST(Messages, TypesAndNames) {
  for (const auto& s : samples::all()) {
    const MessageType t = type_of(s.envelope.message);
    EXPECT_NE(to_string(t), "Unknown");
    EXPECT_EQ(is_request(t), (static_cast<unsigned>(t) >> 8) == 1) << to_string(t);
  }
  EXPECT_EQ(to_string(MessageType::kMeasureDoorWidth), "MeasureDoorWidth");
  EXPECT_EQ(to_string(static_cast<MessageType>(0x0999)), "Unknown");
  EXPECT_FALSE(is_request(static_cast<MessageType>(0x0199)));
  EXPECT_EQ(to_string(ProcedureState::kReadyToAlign), "ready_to_align");
  EXPECT_EQ(to_string(Role::kController), "controller");
}

}  // namespace
}  // namespace ajar::protocol
