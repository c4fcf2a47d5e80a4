// Codec unit tests: hand-written frames (bytes typed in from the spec, CRCs computed with an
// independent bitwise CRC-32C), round trips of every message, encoding; the decoder's checks are in
// codec_decode_test.cpp.
#include <gtest/gtest.h>

// GCC 12 with -fsanitize=address reports -Wmaybe-uninitialized for inactive alternatives of
// std::variant temporaries (Ack{..., PlaneAck/EmptyAck}) built inline: a known false positive.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include <bit>
#include <cstring>
#include <limits>
#include <vector>

#include "ajar/protocol/codec.hpp"
#include "frame_bytes.hpp"
#include "samples.hpp"

namespace ajar::protocol {
namespace {

TEST(Crc32c, CheckValue) {
  const std::string_view s = "123456789";
  const auto* p = reinterpret_cast<const std::uint8_t*>(s.data());
  EXPECT_EQ(crc32c({p, s.size()}), 0xE3069283u);
  EXPECT_EQ(crc32c({}), 0u);
}

TEST(HandWritten, PingDecodesAndEncodes) {
  const Bytes frame = {
      0x41, 0x4a, 0x41, 0x52,                          // magic "AJAR"
      0x01, 0x00,                                      // version 1.0
      0x02, 0x01,                                      // type 0x0102 Ping
      0x00, 0x00,                                      // flags
      0x0d, 0x0c, 0x0b, 0x0a,                          // request id 0x0A0B0C0D
      0x08, 0x00, 0x00, 0x00,                          // payload length 8
      0x29, 0xca, 0xfa, 0x22,                          // CRC-32C
      0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01,  // client_time_ns
  };
  const auto out = decode_frame(frame);
  ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage) << to_string(out.error.code);
  EXPECT_EQ(out.envelope.request_id, 0x0A0B0C0Du);
  EXPECT_EQ(out.envelope.flags, 0);
  ASSERT_TRUE(std::holds_alternative<Ping>(out.envelope.message));
  EXPECT_EQ(std::get<Ping>(out.envelope.message).client_time_ns, 0x0102030405060708ull);
  // A 1.0 frame (header minor 0): this library still speaks 1.0.
  EXPECT_EQ(encode_bytes(Envelope{0x0A0B0C0D, 0, Ping{0x0102030405060708ull}}, 0), frame);
}

TEST(HandWritten, SetContactPointInBaseFrame) {
  const Bytes frame = {
      0x41, 0x4a, 0x41, 0x52, 0x01, 0x00, 0x13, 0x01,  // type 0x0113 SetContactPoint
      0x00, 0x00, 0x07, 0x00, 0x00, 0x00,              // request id 7
      0x19, 0x00, 0x00, 0x00,                          // payload length 25
      0xd9, 0x1b, 0x88, 0xd7,                          // CRC-32C
      0x01,                                            // frame: base
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x3f,  // x = 1.0
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0,  // y = -2.0
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f,  // z = 0.5
  };
  const auto out = decode_frame(frame);
  ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage) << to_string(out.error.code);
  const auto& m = std::get<SetContactPoint>(out.envelope.message);
  EXPECT_EQ(m.contact.frame, core::Frame::kBase);
  EXPECT_EQ(m.contact.position_m, core::Vec3(1.0, -2.0, 0.5));
  EXPECT_EQ(encode_bytes(
                Envelope{7, 0, SetContactPoint{{core::Frame::kBase, core::Vec3(1, -2, 0.5)}}}, 0),
            frame);
}

TEST(HandWritten, EmptyAckOfStop) {
  const Bytes frame = {
      0x41, 0x4a, 0x41, 0x52, 0x01, 0x00, 0x03, 0x02,  // type 0x0203 Ack
      0x00, 0x00, 0x0a, 0x00, 0x00, 0x00,              // request id 10 (echoed)
      0x03, 0x00, 0x00, 0x00,                          // payload length 3
      0xef, 0xc3, 0xee, 0x21,                          // CRC-32C
      0x30, 0x01,                                      // acknowledged: 0x0130 Stop
      0x05,                                            // state: aligned
  };
  const auto out = decode_frame(frame);
  ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage) << to_string(out.error.code);
  const auto& ack = std::get<Ack>(out.envelope.message);
  EXPECT_EQ(ack.acknowledged, MessageType::kStop);
  EXPECT_EQ(ack.state, ProcedureState::kAligned);
  EXPECT_TRUE(std::holds_alternative<EmptyAck>(ack.body));
  EXPECT_EQ(encode_bytes(Envelope{10, 0, Ack{MessageType::kStop, ProcedureState::kAligned, {}}}, 0),
            frame);
}

TEST(HandWritten, Drive11) {
  const Bytes frame = {
      0x41, 0x4a, 0x41, 0x52, 0x01, 0x01, 0x22, 0x01,  // version 1.1, type 0x0122 Drive
      0x00, 0x00, 0x10, 0x00, 0x00, 0x00,              // request id 16
      0x10, 0x00, 0x00, 0x00,                          // payload length 16
      0x00, 0x00, 0x00, 0x00,                          // CRC-32C (filled below)
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xd0, 0x3f,  // linear_m_s = 0.25
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0xbf,  // angular_rad_s = -0.125
  };
  Bytes b = frame;
  refresh_crc(b);
  const auto out = decode_frame(b);
  ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage) << describe(out.error);
  const auto& m = std::get<Drive>(out.envelope.message);
  EXPECT_EQ(m.linear_m_s, 0.25);
  EXPECT_EQ(m.angular_rad_s, -0.125);
  EXPECT_EQ(encode_bytes(Envelope{16, 0, Drive{0.25, -0.125}}, 1), b);
  // The same type in a frame that says 1.0: 1.0 has no Drive.
  b[kOffsetVersionMinor] = 0;
  refresh_crc(b);
  const auto e = decode_frame(b);
  ASSERT_EQ(e.kind, StreamDecoder::Kind::kError);
  EXPECT_EQ(e.error.code, ErrorCode::kUnknownMessageType);
  EXPECT_EQ(describe(e.error),
            "header.type 0x0122 (Drive) is defined from protocol 1.1; the frame says 1.0");
  // And this library refuses to encode it as 1.0.
  std::array<std::uint8_t, kMaxFrameSize> buffer{};
  EXPECT_EQ(encode(Envelope{16, 0, Drive{}}, buffer, 0), 0u);
  EXPECT_EQ(encode(Envelope{16, 0, Ping{}}, buffer, 3), 0u);  // no such minor here
}

// A 1.0 peer's Status, Telemetry and Welcome have the 1.0 lengths; the 1.1 fields read as 0.
TEST(Compatibility, OneZeroLayoutsRoundTrip) {
  for (const auto& s : samples::all()) {
    const MessageType t = type_of(s.envelope.message);
    if (minor_of(t) > 0) continue;
    const auto* ack = std::get_if<Ack>(&s.envelope.message);
    if (ack != nullptr && minor_of(ack->acknowledged) > 0) continue;
    SCOPED_TRACE(s.name);
    const Bytes old = encode_bytes(s.envelope, 0);
    EXPECT_EQ(old[5], 0);
    const auto out = decode_frame(old);
    ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage) << describe(out.error);
    EXPECT_EQ(encode_bytes(out.envelope, 0), old);
  }
  const auto size_at = [](Message m, std::uint8_t minor) {
    return encode_bytes(Envelope{0, 0, std::move(m)}, minor).size() - kHeaderSize;
  };
  EXPECT_EQ(size_at(Welcome{}, 0), 72u);
  EXPECT_EQ(size_at(Status{}, 0), 285u);
  EXPECT_EQ(size_at(Telemetry{}, 0), 87u);
  EXPECT_EQ(size_at(Welcome{}, 1), 73u);
  EXPECT_EQ(size_at(Status{}, 1), 464u);
  EXPECT_EQ(size_at(Telemetry{}, 1), 263u);

  // Decoded from 1.0, the appended fields are at their defaults even when the decoder's message
  // held a 1.1 Status before (the decoder reuses storage).
  Status full;
  full.odometry_x_m = 3.5;
  full.realtime.memory_locked = true;
  full.timing.all.samples = 9;
  StreamDecoder decoder;
  Bytes stream = encode_bytes(Envelope{1, 0, full});
  const Bytes old = encode_bytes(Envelope{2, 0, full}, 0);
  stream.insert(stream.end(), old.begin(), old.end());
  std::span<const std::uint8_t> in(stream);
  StreamDecoder::Outcome outcome;
  in = in.subspan(decoder.feed(in, outcome));
  ASSERT_EQ(outcome.kind, StreamDecoder::Kind::kMessage);
  EXPECT_EQ(std::get<Status>(outcome.envelope.message).odometry_x_m, 3.5);
  in = in.subspan(decoder.feed(in, outcome));
  ASSERT_EQ(outcome.kind, StreamDecoder::Kind::kMessage);
  const auto& s10 = std::get<Status>(outcome.envelope.message);
  EXPECT_EQ(s10.odometry_x_m, 0.0);
  EXPECT_FALSE(s10.realtime.memory_locked);
  EXPECT_EQ(s10.timing.all.samples, 0u);
  EXPECT_TRUE(in.empty());

  // A 1.0 frame with the 1.1 length, and a 1.1 frame with the 1.0 length, are both refused.
  Bytes b = encode_bytes(Envelope{3, 0, Status{}});
  b[kOffsetVersionMinor] = 0;
  refresh_crc(b);
  auto e = decode_frame(b);
  ASSERT_EQ(e.kind, StreamDecoder::Kind::kError);
  EXPECT_EQ(e.error.code, ErrorCode::kBadPayloadLength);
  EXPECT_EQ(describe(e.error),
            "header.payload_length is 616: Status in protocol 1.0 has 285 bytes");
  b = encode_bytes(Envelope{3, 0, Status{}}, 0);
  b[kOffsetVersionMinor] = 1;
  refresh_crc(b);
  e = decode_frame(b);
  ASSERT_EQ(e.kind, StreamDecoder::Kind::kError);
  EXPECT_EQ(describe(e.error),
            "header.payload_length is 285: Status in protocol 1.1 has 464 bytes");
  // An Ack of a 1.1 request cannot be 1.0.
  std::array<std::uint8_t, kMaxFrameSize> out{};
  EXPECT_EQ(encode(Envelope{1, 0, Ack{MessageType::kDrive, {}, EmptyAck{}}}, out, 0), 0u);
}

TEST(Describe, SentencesNameTheFieldAndWhy) {
  Bytes b = encode_bytes(Envelope{3, 0, MeasureDoorWidth{}});
  const auto patch = [&b](std::size_t at, std::uint8_t v) {
    b[kHeaderSize + at] = v;
    refresh_crc(b);
  };
  patch(25 + 1 + 16 + 6, 0xF8);  // p2.z high bytes 0xFFF8: NaN
  patch(25 + 1 + 16 + 7, 0xFF);
  EXPECT_EQ(describe(decode_frame(b).error), "p2.z is NaN: numbers on the wire must be finite");
  b = encode_bytes(Envelope{3, 0, MeasureDoorWidth{}});
  patch(0, 5);
  EXPECT_EQ(describe(decode_frame(b).error), "p1.frame is 5: allowed values are 0..1");
  b = encode_bytes(Envelope{3, 0, Reset{}});
  patch(0, 2);
  EXPECT_EQ(describe(decode_frame(b).error), "clear_parameters is 2: a bool is 0 or 1");
  b = encode_bytes(Envelope{3, 0, Ping{}});
  b[kOffsetFlags + 1] = 0x40;
  refresh_crc(b);
  EXPECT_EQ(describe(decode_frame(b).error),
            "header.flags is 0x4000: reserved bits set (this version knows 0x0001): not executed");
  b = encode_bytes(Envelope{3, 0, Ping{}});
  b[kOffsetType] = 0x99;
  refresh_crc(b);
  EXPECT_EQ(describe(decode_frame(b).error),
            "header.type 0x0199 is not a message type of protocol 1.2: not executed");
  b = encode_bytes(Envelope{3, 0, Ping{}});
  b.pop_back();
  set_length(b);
  EXPECT_EQ(describe(decode_frame(b).error),
            "header.payload_length is 7: Ping in protocol 1.2 has 8 bytes");
  Hello hello;
  hello.client_name = "abc";
  b = encode_bytes(Envelope{3, 0, hello});
  patch(12 + 1 + 10, 'x');
  EXPECT_EQ(describe(decode_frame(b).error),
            "client_name: non-zero padding (length 3, capacity 32)");
  MeasureDoorPlane plane;
  plane.count = 3;
  b = encode_bytes(Envelope{3, 0, plane});
  patch(0, 2);
  EXPECT_EQ(describe(decode_frame(b).error), "count is 2: allowed 3..16");
  b = encode_bytes(Envelope{3, 0, Ping{}});
  b[kOffsetVersionMajor] = 2;
  refresh_crc(b);
  EXPECT_EQ(describe(decode_frame(b).error),
            "header.version_major is 2: this peer speaks protocol 1.x only: closing the "
            "connection");
  for (const auto& s : samples::all()) {  // every sentence fits ErrorReply::message
    Bytes f = encode_bytes(s.envelope);
    f[kHeaderSize + (f.size() > kHeaderSize ? 0 : 0)] ^= 0;
    f.push_back(0);
    set_length(f);
    EXPECT_LE(describe(decode_frame(f).error).size(), 200u);
  }
}

TEST(RoundTrip, EverySampleDecodesToTheSameValue) {
  for (const auto& s : samples::all()) {
    SCOPED_TRACE(s.name);
    const Bytes frame = encode_bytes(s.envelope);
    const auto out = decode_frame(frame);
    ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage) << to_string(out.error.code);
    EXPECT_EQ(type_of(out.envelope.message), type_of(s.envelope.message));
    EXPECT_EQ(out.envelope.request_id, s.envelope.request_id);
    EXPECT_EQ(out.envelope.flags, s.envelope.flags);
    EXPECT_TRUE(wire_equal(out.envelope.message, s.envelope.message));
    EXPECT_EQ(encode_bytes(out.envelope), frame);
  }
}

TEST(RoundTrip, FieldValuesSurvive) {
  // wire_equal compares encodings; check a few decoded values directly as well.
  Status st;
  st.plane = samples::plane_ack();
  st.has_plane = true;
  st.latched_fault = ErrorCode::kDeadman;
  st.loop = samples::loop_stats();
  const auto out = decode_frame(encode_bytes(Envelope{1, 0, st}));
  ASSERT_EQ(out.kind, StreamDecoder::Kind::kMessage);
  const auto& d = std::get<Status>(out.envelope.message);
  EXPECT_NE(st.plane.left_counts, 0);
  EXPECT_EQ(d.plane.left_counts, st.plane.left_counts);
  EXPECT_EQ(d.plane.normal, st.plane.normal);
  EXPECT_TRUE(d.has_plane);
  EXPECT_FALSE(d.has_width);
  EXPECT_EQ(d.latched_fault, ErrorCode::kDeadman);
  EXPECT_EQ(d.loop.cycles, 123456789u);
  EXPECT_EQ(d.loop.rate_hz, 1000.0f);
}

TEST(Encode, SizesFollowTheSpec) {
  const auto size_of = [](Message m) { return encode_bytes(Envelope{0, 0, std::move(m)}).size(); };
  EXPECT_EQ(size_of(Hello{}), kHeaderSize + 45);
  EXPECT_EQ(size_of(Ping{}), kHeaderSize + 8);
  EXPECT_EQ(size_of(MeasureDoorWidth{}), kHeaderSize + 50);
  EXPECT_EQ(size_of(SetContactPoint{}), kHeaderSize + 25);
  EXPECT_EQ(size_of(Engage{}), kHeaderSize);
  EXPECT_EQ(size_of(Reset{}), kHeaderSize + 1);
  EXPECT_EQ(size_of(Subscribe{}), kHeaderSize + 4);
  EXPECT_EQ(size_of(Welcome{}), kHeaderSize + 73);
  EXPECT_EQ(size_of(Pong{}), kHeaderSize + 16);
  EXPECT_EQ(size_of(ErrorReply{}), kHeaderSize + 238);
  EXPECT_EQ(size_of(Event{}), kHeaderSize + 134);      // 1.2: base_motion appended
  EXPECT_EQ(size_of(Status{}), kHeaderSize + 616);     // 464 in 1.1, 465 + RecorderState
  EXPECT_EQ(size_of(Telemetry{}), kHeaderSize + 264);  // 263 in 1.1
  EXPECT_EQ(size_of(Drive{}), kHeaderSize + 16);
  EXPECT_EQ(size_of(Approach{}), kHeaderSize + 8);
  EXPECT_EQ(size_of(GetRobotModel{}), kHeaderSize);
  EXPECT_EQ(size_of(ResetLoopStatistics{}), kHeaderSize);
  RobotModel model;
  model.left.polarity = 1;
  EXPECT_EQ(size_of(model), kHeaderSize + 388);
  EXPECT_EQ(size_of(Ack{MessageType::kApproach, {}, ApproachAck{}}), kHeaderSize + 3 + 32);
  EXPECT_EQ(size_of(Ack{MessageType::kMeasureDoorWidth, {}, SpanAck{}}), kHeaderSize + 3 + 57);
  EXPECT_EQ(size_of(Ack{MessageType::kMeasureDoorPlane, {}, PlaneAck{}}), kHeaderSize + 3 + 81);
  EXPECT_EQ(size_of(Ack{MessageType::kSetContactPoint, {}, ContactAck{}}), kHeaderSize + 3 + 32);
  MeasureDoorPlane plane;
  plane.count = 5;
  EXPECT_EQ(size_of(plane), kHeaderSize + 1 + 5 * 25);
}

TEST(Encode, RefusesInconsistentMessages) {
  std::array<std::uint8_t, kMaxFrameSize> out{};
  // Ack body must match what is acknowledged.
  EXPECT_EQ(encode(Envelope{1, 0, Ack{MessageType::kMeasureDoorWidth, {}, EmptyAck{}}}, out), 0u);
  EXPECT_EQ(encode(Envelope{1, 0, Ack{MessageType::kAlignBase, {}, SpanAck{}}}, out), 0u);
  // Only requests are acknowledged.
  EXPECT_EQ(encode(Envelope{1, 0, Ack{MessageType::kWelcome, {}, EmptyAck{}}}, out), 0u);
  MeasureDoorPlane plane;
  plane.count = 17;
  EXPECT_EQ(encode(Envelope{1, 0, plane}, out), 0u);
  plane.count = 2;
  EXPECT_EQ(encode(Envelope{1, 0, plane}, out), 0u);
  // Too small an output buffer.
  EXPECT_EQ(encode(Envelope{1, 0, Ping{}}, std::span(out).first(kHeaderSize + 7)), 0u);
  EXPECT_EQ(encode(Envelope{1, 0, Ping{}}, std::span(out).first(kHeaderSize + 8)), kHeaderSize + 8);
  Bytes v = {1, 2, 3};
  EXPECT_FALSE(encode_append(Envelope{1, 0, Ack{MessageType::kWelcome, {}, {}}}, v));
  EXPECT_EQ(v, (Bytes{1, 2, 3}));
}

}  // namespace
}  // namespace ajar::protocol
