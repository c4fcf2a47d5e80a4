// Protocol 1.0 against the 1.1 daemon (docs/protocol.md section 7): a client that says Hello with
// minor 0 and writes 1.0 headers gets every frame (Welcome, Status, Telemetry, events) with a 1.0
// header and the 1.0 layout, byte-exact; a 1.1 type in a 1.0 frame is refused and the session
// continues; a 1.1 session on the same daemon gets the 1.1 layouts. The bytes are read raw from
// the socket, not through this tree's (1.1) decoder.
#include <utility>  // before Asio (asio issue 944)

#include <array>
#include <vector>

#include <boost/asio/read.hpp>
#include <gtest/gtest.h>

#include "test_client.hpp"
#include "test_client_harness.hpp"

namespace ajar::test {
namespace {

using protocol::MessageType;
using protocol::Role;
using Bytes = std::vector<std::uint8_t>;

Bytes frame_at(const protocol::Message& m, std::uint32_t id, std::uint8_t minor) {
  Bytes out;
  EXPECT_TRUE(protocol::encode_append(protocol::Envelope{id, 0, m}, out, minor));
  return out;
}

struct RawFrame {
  protocol::FrameHeader header;
  Bytes bytes;  // header + payload
};

// Reads one whole frame from the socket, byte-exact.
RawFrame read_frame(asio::ip::tcp::socket& socket) {
  RawFrame f;
  f.bytes.resize(protocol::kHeaderSize);
  asio::read(socket, asio::buffer(f.bytes));
  std::array<std::uint8_t, protocol::kHeaderSize> h{};
  std::copy(f.bytes.begin(), f.bytes.end(), h.begin());
  f.header = protocol::decode_header(h);
  EXPECT_LE(f.header.payload_length, protocol::kMaxPayloadSize);
  f.bytes.resize(protocol::kHeaderSize + f.header.payload_length);
  asio::read(socket, asio::buffer(f.bytes.data() + protocol::kHeaderSize, f.header.payload_length));
  return f;
}

// The next frame of `type` (skipping events and telemetry that may arrive in between).
RawFrame read_until(asio::ip::tcp::socket& socket, MessageType type) {
  for (int i = 0; i < 1000; ++i) {
    RawFrame f = read_frame(socket);
    if (f.header.type == static_cast<std::uint16_t>(type)) return f;
  }
  ADD_FAILURE() << "no " << protocol::to_string(type) << " frame";
  return {};
}

class ProtocolVersions : public ::testing::Test {
 protected:
  FakeEngine engine_;
  ServerThread server_{engine_, daemon::ServerOptions{}};
};

TEST_F(ProtocolVersions, AOneZeroClientGetsOneZeroFramesByteExact) {
  TestClient c(server_.port());
  auto hello = hello_as(Role::kController);
  hello.version_minor = 0;
  c.send_raw(frame_at(hello, 1, 0));
  const RawFrame welcome = read_until(c.socket(), MessageType::kWelcome);
  EXPECT_EQ(welcome.header.version_minor, 0);
  EXPECT_EQ(welcome.header.payload_length, 72u);  // the 1.0 Welcome: no driver_kind
  EXPECT_EQ(welcome.header.request_id, 1u);

  // Every frame the daemon sends is exactly what a 1.0 encoder makes of the decoded message.
  const auto same_as_1_0_encoding = [](const RawFrame& f) {
    const auto out = protocol::decode_frame(f.bytes);
    EXPECT_EQ(out.kind, protocol::StreamDecoder::Kind::kMessage) << protocol::describe(out.error);
    EXPECT_EQ(frame_at(out.envelope.message, out.envelope.request_id, 0), f.bytes);
  };
  same_as_1_0_encoding(welcome);

  c.send_raw(frame_at(protocol::GetStatus{}, 2, 0));
  const RawFrame status = read_until(c.socket(), MessageType::kStatus);
  EXPECT_EQ(status.header.version_minor, 0);
  EXPECT_EQ(status.header.payload_length, 285u);
  same_as_1_0_encoding(status);

  c.send_raw(frame_at(protocol::Subscribe{100.0F}, 3, 0));
  const RawFrame telemetry = read_until(c.socket(), MessageType::kTelemetry);
  EXPECT_EQ(telemetry.header.version_minor, 0);
  EXPECT_EQ(telemetry.header.payload_length, 87u);
  same_as_1_0_encoding(telemetry);
  c.send_raw(frame_at(protocol::Subscribe{0.0F}, 4, 0));

  protocol::Event event;
  event.kind = protocol::EventKind::kMotionFinished;
  event.detail = "done";
  engine_.emit(event);
  const RawFrame e = read_until(c.socket(), MessageType::kEvent);
  EXPECT_EQ(e.header.version_minor, 0);
  same_as_1_0_encoding(e);

  // A 1.1 type in a 1.0 frame: refused, not executed, the session continues.
  Bytes drive = frame_at(protocol::Drive{0.1, 0.0}, 5, 1);
  drive[5] = 0;
  fix_crc(drive);
  c.send_raw(drive);
  const RawFrame refused = read_until(c.socket(), MessageType::kError);
  const auto decoded = protocol::decode_frame(refused.bytes);
  ASSERT_EQ(decoded.kind, protocol::StreamDecoder::Kind::kMessage);
  const auto& error = std::get<protocol::ErrorReply>(decoded.envelope.message);
  EXPECT_EQ(error.code, ErrorCode::kUnknownMessageType);
  EXPECT_EQ(error.field.view(), "header.type");
  EXPECT_EQ(refused.header.request_id, 5u);
  EXPECT_EQ(engine_.count(MessageType::kDrive), 0u);

  // A 1.1 frame of a 1.1 type on a session whose Hello said 1.0: refused the same way.
  c.send_raw(frame_at(protocol::GetRobotModel{}, 6, 1));
  const RawFrame refused_too = read_until(c.socket(), MessageType::kError);
  EXPECT_EQ(refused_too.header.request_id, 6u);
  EXPECT_EQ(refused_too.header.version_minor, 0);

  c.send_raw(frame_at(protocol::Ping{7}, 7, 0));
  EXPECT_EQ(read_until(c.socket(), MessageType::kPong).header.version_minor, 0);
}

TEST_F(ProtocolVersions, AOneOneSessionOnTheSameDaemonGetsOneOneLayouts) {
  TestClient old(server_.port());
  auto hello_old = hello_as(Role::kObserver);
  hello_old.version_minor = 0;
  old.send_raw(frame_at(hello_old, 1, 0));
  EXPECT_EQ(read_until(old.socket(), MessageType::kWelcome).header.payload_length, 72u);

  TestClient c(server_.port());
  auto hello_1_1 = hello_as(Role::kObserver);
  hello_1_1.version_minor = 1;  // a 1.1 client on this 1.2 daemon
  c.send_raw(frame_at(hello_1_1, 1, 1));
  const RawFrame welcome = read_until(c.socket(), MessageType::kWelcome);
  EXPECT_EQ(welcome.header.version_minor, 1);
  EXPECT_EQ(welcome.header.payload_length, 73u);
  c.send_raw(frame_at(protocol::GetStatus{}, 2, 1));
  const RawFrame status = read_until(c.socket(), MessageType::kStatus);
  EXPECT_EQ(status.header.version_minor, 1);
  EXPECT_EQ(status.header.payload_length, 464u);
  c.send_raw(frame_at(protocol::GetRobotModel{}, 3, 1));
  EXPECT_EQ(read_until(c.socket(), MessageType::kRobotModel).header.request_id, 3u);
  // A 1.2 request on the 1.1 session (in a 1.2 frame): refused, the session goes on.
  c.send_raw(frame_at(protocol::ListRecordings{}, 4, 2));
  const RawFrame refused = read_until(c.socket(), MessageType::kError);
  EXPECT_EQ(refused.header.version_minor, 1);
  EXPECT_EQ(refused.header.request_id, 4u);

  TestClient now(server_.port());  // a 1.2 client: Status and Event carry base_motion, Status
                                   // the recorder's state (1.2)
  now.send_raw(frame_at(hello_as(Role::kObserver), 1, 2));
  EXPECT_EQ(read_until(now.socket(), MessageType::kWelcome).header.version_minor, 2);
  now.send_raw(frame_at(protocol::GetStatus{}, 2, 2));
  EXPECT_EQ(read_until(now.socket(), MessageType::kStatus).header.payload_length, 616u);

  // One event, three layouts: each session gets its own minor's header and length.
  protocol::Event event;
  event.kind = protocol::EventKind::kStateChanged;
  event.base_motion = protocol::BaseMotion::kJogging;
  engine_.emit(event);
  const RawFrame old_event = read_until(old.socket(), MessageType::kEvent);
  EXPECT_EQ(old_event.header.version_minor, 0);
  EXPECT_EQ(old_event.header.payload_length, 133u);
  const RawFrame event_1_1 = read_until(c.socket(), MessageType::kEvent);
  EXPECT_EQ(event_1_1.header.version_minor, 1);
  EXPECT_EQ(event_1_1.header.payload_length, 133u);
  const RawFrame event_1_2 = read_until(now.socket(), MessageType::kEvent);
  EXPECT_EQ(event_1_2.header.version_minor, 2);
  EXPECT_EQ(event_1_2.header.payload_length, 134u);
  EXPECT_EQ(event_1_2.bytes.back(), 3);  // base_motion: jogging
}

TEST_F(ProtocolVersions, DecodeErrorsCarryASentenceNamingTheFieldAndWhy) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  Bytes frame = frame_at(protocol::Subscribe{10.0F}, 9, 1);
  put_u32(frame, protocol::kHeaderSize, 0x7FC00000);  // NaN
  fix_crc(frame);
  c.send_raw(frame);
  const auto reply = c.reply_to(9);
  ASSERT_EQ(error_code_of(reply), ErrorCode::kNonFiniteNumber);
  const auto& error = std::get<protocol::ErrorReply>(reply);
  EXPECT_EQ(error.field.view(), "telemetry_rate_hz");
  EXPECT_EQ(error.message.view(), "telemetry_rate_hz is NaN: numbers on the wire must be finite");
}

}  // namespace
}  // namespace ajar::test
