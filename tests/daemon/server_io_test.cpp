// The server's byte-level guarantees over loopback, against a fake engine: malformed frames affect
// only their own session, max-clients refusal, read deadline, slow readers dropped, frames in any
// chunking, hundreds of concurrent sessions.
#include <memory>
#include <thread>

#include <gtest/gtest.h>

#include "ajar/daemon/config.hpp"
#include "test_client.hpp"
#include "test_client_harness.hpp"

namespace ajar::test {
namespace {

using protocol::Role;

daemon::ServerOptions small_options() {
  daemon::ServerOptions o;
  o.max_clients = 8;
  o.session.send_queue_frames = 16;
  o.session.read_deadline = 300ms;
  o.session.linger = 500ms;
  return o;
}

void expect_pong(TestClient& c) {
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(c.request(protocol::Ping{1})));
  EXPECT_FALSE(c.closed());
}

class ServerIo : public ::testing::Test {
 protected:
  FakeEngine engine_;
  ServerThread server_{engine_, small_options()};

  // A bystander session that must not notice what happens to others.
  void expect_bystander_fine(TestClient& bystander) {
    EXPECT_TRUE(std::holds_alternative<protocol::Pong>(bystander.request(protocol::Ping{1})));
    EXPECT_FALSE(bystander.closed());
  }
};

TEST_F(ServerIo, BadCrcIsReportedWithTheRequestIdAndTheSessionContinues) {
  TestClient bystander(server_.port());
  bystander.hello(Role::kObserver);
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  auto frame = frame_of(protocol::Ping{5}, 31);
  frame.back() ^= 0x01;  // payload bit flip
  c.send_raw(frame);
  const auto reply = c.reply_to(31);
  ASSERT_EQ(error_code_of(reply), ErrorCode::kCrcMismatch);
  EXPECT_EQ(std::get<protocol::ErrorReply>(reply).field.view(), "header.crc");
  EXPECT_EQ(std::get<protocol::ErrorReply>(reply).offending_type, protocol::MessageType::kPing);
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(c.request(protocol::Ping{6})));
  expect_bystander_fine(bystander);
}

TEST_F(ServerIo, UnknownMessageTypeIsReportedAndTheSessionContinues) {
  TestClient bystander(server_.port());
  bystander.hello(Role::kObserver);
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  auto frame = frame_of(protocol::Ping{5}, 32);
  put_u16(frame, 6, 0x0999);
  fix_crc(frame);
  c.send_raw(frame);
  const auto reply = c.reply_to(32);
  ASSERT_EQ(error_code_of(reply), ErrorCode::kUnknownMessageType);
  EXPECT_EQ(static_cast<std::uint16_t>(std::get<protocol::ErrorReply>(reply).offending_type),
            0x0999);
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(c.request(protocol::Ping{6})));
  expect_bystander_fine(bystander);
}

TEST_F(ServerIo, UnknownFlagsAreReported) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  c.send_raw(frame_of(protocol::Ping{5}, 33, 0x8000));
  EXPECT_EQ(error_code_of(c.reply_to(33)), ErrorCode::kUnknownFlags);
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(c.request(protocol::Ping{6})));
}

TEST_F(ServerIo, InvalidFieldsAreReportedWithTheField) {
  TestClient c(server_.port());
  c.hello(Role::kController);
  auto frame = frame_of(protocol::Hello{}, 34);  // role byte at payload offset 2
  frame[protocol::kHeaderSize + 2] = 9;
  fix_crc(frame);
  c.send_raw(frame);
  const auto reply = c.reply_to(34);
  ASSERT_EQ(error_code_of(reply), ErrorCode::kInvalidEnumValue);
  EXPECT_EQ(std::get<protocol::ErrorReply>(reply).field.view(), "requested_role");
  EXPECT_TRUE(engine_.commands().empty());
}

TEST_F(ServerIo, BadMagicClosesOnlyThatSessionAfterTheErrorReply) {
  TestClient bystander(server_.port());
  bystander.hello(Role::kObserver);
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  auto frame = frame_of(protocol::Ping{5}, 35);
  frame[0] = 'X';
  c.send_raw(frame);
  auto outcome = c.next();
  ASSERT_TRUE(outcome && outcome->kind == protocol::StreamDecoder::Kind::kMessage);
  EXPECT_EQ(error_code_of(outcome->envelope.message), ErrorCode::kBadMagic);
  EXPECT_TRUE(c.wait_closed());
  expect_bystander_fine(bystander);
}

TEST_F(ServerIo, OversizePayloadClosesOnlyThatSession) {
  TestClient bystander(server_.port());
  bystander.hello(Role::kController);
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  auto frame = frame_of(protocol::Ping{5}, 36);
  put_u32(frame, 14, 1'000'000);
  frame.resize(protocol::kHeaderSize);
  c.send_raw(frame);
  const auto reply = c.reply_to(36);
  EXPECT_EQ(error_code_of(reply), ErrorCode::kPayloadTooLarge);
  EXPECT_TRUE(c.wait_closed());
  expect_bystander_fine(bystander);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(bystander.request(protocol::AlignBase{})));
}

TEST_F(ServerIo, FramesArriveInAnyChunking) {
  TestClient c(server_.port());
  std::vector<std::uint8_t> bytes = frame_of(hello_as(Role::kObserver), 1);
  const auto ping = frame_of(protocol::Ping{77}, 2);
  bytes.insert(bytes.end(), ping.begin(), ping.end());
  for (std::uint8_t b : bytes) {
    ASSERT_TRUE(c.send_raw(std::span<const std::uint8_t>(&b, 1)));
  }
  EXPECT_TRUE(std::holds_alternative<protocol::Welcome>(c.reply_to(1)));
  const auto pong = c.reply_to(2);
  ASSERT_TRUE(std::holds_alternative<protocol::Pong>(pong));
  EXPECT_EQ(std::get<protocol::Pong>(pong).client_time_ns, 77U);
}

TEST_F(ServerIo, AHalfSentFrameHitsTheReadDeadline) {
  TestClient bystander(server_.port());
  bystander.hello(Role::kObserver);
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  const auto frame = frame_of(protocol::Ping{5}, 37);
  c.send_raw(std::span<const std::uint8_t>(frame.data(), 10));
  EXPECT_TRUE(c.wait_closed());
  // Not silently: an Error naming the deadline came first.
  ASSERT_EQ(c.others().size(), 1U);
  const auto& error = c.others().front().message;
  ASSERT_EQ(error_code_of(error), ErrorCode::kBadPayloadLength);
  EXPECT_EQ(std::get<protocol::ErrorReply>(error).field.view(), "read_deadline_s");
  EXPECT_NE(std::get<protocol::ErrorReply>(error).message.view().find("10 bytes"),
            std::string_view::npos);
  expect_bystander_fine(bystander);
}

// Before: the read deadline's Error was written in the daemon's own minor, also to a 1.0 session
// (docs/protocol.md 7.1: every frame to a session has the minor its Hello settled).
TEST_F(ServerIo, TheReadDeadlinesErrorToA10SessionIsA10Frame) {
  TestClient c(server_.port());
  protocol::Hello hello = hello_as(Role::kObserver);
  hello.version_minor = 0;
  ASSERT_TRUE(std::holds_alternative<protocol::Welcome>(c.reply_to(c.send(hello))));
  const auto frame = frame_of(protocol::Ping{5}, 38);
  c.send_raw(std::span<const std::uint8_t>(frame.data(), 10));
  std::vector<std::uint8_t> bytes;  // what the daemon writes until it closes, raw
  for (;;) {
    std::array<std::uint8_t, 512> buffer{};
    boost::system::error_code ec;
    const std::size_t n = c.socket().read_some(asio::buffer(buffer), ec);
    bytes.insert(bytes.end(), buffer.begin(), buffer.begin() + static_cast<long>(n));
    if (ec) break;
  }
  ASSERT_GE(bytes.size(), protocol::kHeaderSize);
  EXPECT_EQ(bytes[5], 0) << "the Error frame's header says 1." << int{bytes[5]};
  EXPECT_EQ(bytes[6] | (bytes[7] << 8), static_cast<int>(protocol::MessageType::kError));
}

// A full table makes room: the observer idle the longest is closed (never the controller) and
// the newcomer is served.
TEST_F(ServerIo, AFullTableClosesTheIdlestObserverForANewcomer) {
  std::vector<std::unique_ptr<TestClient>> clients;
  for (int i = 0; i < 8; ++i) {
    clients.push_back(std::make_unique<TestClient>(server_.port()));
    clients.back()->hello(i == 0 ? Role::kController : Role::kObserver);
  }
  for (std::size_t i = 2; i < clients.size(); ++i)  // everybody but clients[1] speaks again
    expect_bystander_fine(*clients[i]);
  expect_bystander_fine(*clients[0]);
  TestClient extra(server_.port());
  EXPECT_EQ(extra.hello(Role::kObserver).granted_role, Role::kObserver);
  EXPECT_TRUE(clients[1]->wait_closed());
  ASSERT_EQ(clients[1]->others().size(), 1U);
  EXPECT_EQ(error_code_of(clients[1]->others().front().message), ErrorCode::kTooManyClients);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(clients[0]->request(protocol::AlignBase{})));
  EXPECT_EQ(server_.session_count(), 8U);
}

// Sockets that never say Hello go first, before any greeted observer.
TEST_F(ServerIo, NeverGreetedSocketsAreClosedBeforeObservers) {
  TestClient observer(server_.port());
  observer.hello(Role::kObserver);
  std::vector<std::unique_ptr<TestClient>> silent;
  for (int i = 0; i < 7; ++i)
    silent.push_back(std::make_unique<TestClient>(server_.port()));
  ASSERT_TRUE(eventually([&] { return server_.session_count() == 8; }));
  std::vector<std::unique_ptr<TestClient>> newcomers;
  for (int i = 0; i < 7; ++i) {
    newcomers.push_back(std::make_unique<TestClient>(server_.port()));
    EXPECT_EQ(newcomers.back()->hello(Role::kObserver).granted_role, Role::kObserver);
  }
  for (auto& c : silent)
    EXPECT_TRUE(c->wait_closed());
  expect_bystander_fine(observer);
}

// Nothing to close (max_clients 1, held by the controller): the newcomer is refused, but its
// EmergencyStop is executed and acknowledged before the connection closes.
TEST(ServerRefusal, ARefusedConnectionsEmergencyStopIsExecuted) {
  FakeEngine engine;
  daemon::ServerOptions options = small_options();
  options.max_clients = 1;
  ServerThread server(engine, options);
  TestClient controller(server.port());
  controller.hello(Role::kController);
  TestClient refused(server.port());
  auto bytes = frame_of(hello_as(Role::kObserver), 1);
  const auto stop = frame_of(protocol::EmergencyStop{}, 2);
  const auto ping = frame_of(protocol::Ping{}, 3);
  bytes.insert(bytes.end(), stop.begin(), stop.end());
  bytes.insert(bytes.end(), ping.begin(), ping.end());
  refused.send_raw(bytes);
  EXPECT_EQ(error_code_of(refused.reply_to(1)), ErrorCode::kTooManyClients);
  const auto ack = refused.reply_to(2);
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(ack)) << TestClient::describe(ack);
  EXPECT_EQ(std::get<protocol::Ack>(ack).acknowledged, protocol::MessageType::kEmergencyStop);
  EXPECT_EQ(error_code_of(refused.reply_to(3)), ErrorCode::kTooManyClients);
  EXPECT_TRUE(refused.wait_closed());
  EXPECT_EQ(engine.count(protocol::MessageType::kEmergencyStop), 1U);
  EXPECT_EQ(engine.count(protocol::MessageType::kPing), 0U);
  expect_pong(controller);
}

TEST(ServerHello, AnUngreetedSocketIsClosedAtTheHelloDeadlineWithAnError) {
  FakeEngine engine;
  daemon::ServerOptions options = small_options();
  options.hello_timeout = 200ms;
  ServerThread server(engine, options);
  TestClient greeted(server.port());
  greeted.hello(Role::kObserver);
  TestClient silent(server.port());
  EXPECT_TRUE(silent.wait_closed());
  ASSERT_EQ(silent.others().size(), 1U);
  const auto& error = silent.others().front().message;
  ASSERT_EQ(error_code_of(error), ErrorCode::kHelloRequired);
  EXPECT_NE(std::get<protocol::ErrorReply>(error).message.view().find("hello_timeout_s"),
            std::string_view::npos);
  expect_pong(greeted);  // a greeted session has no such deadline
  EXPECT_FALSE(greeted.closed());
}

TEST_F(ServerIo, AClientThatStopsReadingIsDroppedWhileOthersContinue) {
  TestClient bystander(server_.port());
  bystander.hello(Role::kObserver);
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(bystander.request(protocol::Subscribe{100})));
  TestClient lazy(server_.port(), 4096);
  lazy.hello(Role::kObserver);
  // Requests keep coming but replies are never read: the daemon's queue (16 frames) overflows
  // once the socket buffers are full.
  const auto request = frame_of(protocol::GetStatus{}, 1);
  std::vector<std::uint8_t> burst;
  for (int i = 0; i < 256; ++i)
    burst.insert(burst.end(), request.begin(), request.end());
  bool dropped = false;
  for (int i = 0; i < 20000 && !dropped; ++i)
    dropped = !lazy.send_raw(burst);
  EXPECT_TRUE(dropped || eventually([&] { return server_.session_count() == 1; }));
  EXPECT_TRUE(eventually([&] { return server_.session_count() == 1; }));
  expect_bystander_fine(bystander);
  const auto before = bystander.telemetry_count();
  EXPECT_TRUE(bystander.wait_telemetry(before + 3));
}

// More replies queued at once than one gather-write takes (64 frames): they leave in the order
// they were queued, none twice, none lost, over the writes that follow.
TEST(ServerQueue, ABurstOfRepliesBeyondOneGatherWriteArrivesInOrder) {
  FakeEngine engine;
  ServerThread server(engine, daemon::ServerOptions{});  // send_queue_frames 512
  TestClient c(server.port());
  c.hello(Role::kObserver);
  constexpr std::uint32_t kPings = 400;  // ~136 per 4 KiB read: more than 64 queue behind a write
  std::vector<std::uint8_t> burst;
  for (std::uint32_t i = 0; i < kPings; ++i) {
    const auto frame = frame_of(protocol::Ping{i}, 1000 + i);
    burst.insert(burst.end(), frame.begin(), frame.end());
  }
  ASSERT_TRUE(c.send_raw(burst));
  for (std::uint32_t i = 0; i < kPings; ++i) {
    const auto outcome = c.next();
    ASSERT_TRUE(outcome) << "reply " << i << " never came";
    ASSERT_EQ(outcome->kind, protocol::StreamDecoder::Kind::kMessage);
    const auto* pong = std::get_if<protocol::Pong>(&outcome->envelope.message);
    ASSERT_NE(pong, nullptr) << i;
    ASSERT_EQ(outcome->envelope.request_id, 1000 + i);
    ASSERT_EQ(pong->client_time_ns, i);
  }
  expect_pong(c);
}

TEST(ServerScale, TwoHundredFiftySixObserversAllGetTelemetryAndEvents) {
  FakeEngine engine;
  daemon::ServerOptions options;
  options.max_clients = 300;
  ServerThread server(engine, options);
  std::vector<std::unique_ptr<TestClient>> clients;
  for (int i = 0; i < 256; ++i) {
    clients.push_back(std::make_unique<TestClient>(server.port()));
    clients.back()->hello(Role::kObserver);
    clients.back()->send(protocol::Subscribe{20});
  }
  protocol::Event event;
  event.kind = protocol::EventKind::kStateChanged;
  event.state = protocol::ProcedureState::kAligning;
  engine.emit(event);
  for (auto& c : clients) {
    ASSERT_TRUE(c->wait_event(protocol::EventKind::kStateChanged));
    ASSERT_TRUE(c->wait_telemetry(2));
  }
  TestClient status(server.port());
  status.hello(Role::kObserver);
  EXPECT_EQ(status.request_as<protocol::Status>(protocol::GetStatus{}).session_count, 257);
}

// A TCP connect means the daemon serves: bound (port known, a busy port fails early) but refused
// until start(), which ajard calls once the engine serves.
TEST(ServerStart, AConnectIsRefusedUntilTheServerServes) {
  FakeEngine engine;
  boost::asio::io_context io{1};
  daemon::ServerOptions options = small_options();
  options.bind_address = "127.0.0.1";
  options.port = 0;
  daemon::Server server(io, engine, options);
  const std::uint16_t port = server.bind();
  ASSERT_NE(port, 0);
  {
    boost::asio::io_context client_io;
    boost::asio::ip::tcp::socket early(client_io);
    boost::system::error_code ec;
    early.connect({boost::asio::ip::make_address("127.0.0.1"), port}, ec);
    EXPECT_EQ(ec, boost::asio::error::connection_refused) << ec.message();
  }
  server.start();
  // A second daemon on the same address fails at bind(), before its engine starts.
  daemon::ServerOptions same = options;
  same.port = port;
  daemon::Server rival(io, engine, same);
  EXPECT_THROW(rival.bind(), daemon::StartupError);

  std::thread thread([&] { io.run(); });
  {
    TestClient c(port);
    EXPECT_EQ(c.hello(Role::kObserver).granted_role, Role::kObserver);
  }
  boost::asio::post(io, [&] { server.stop(); });
  thread.join();
}

}  // namespace
}  // namespace ajar::test
