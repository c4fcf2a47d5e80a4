// Session rules over real loopback sockets, against a fake engine: Hello first, roles, take-over,
// heartbeats, exactly-once, subscriptions, decode errors.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "test_client.hpp"
#include "test_client_harness.hpp"

namespace ajar::test {
namespace {

using protocol::MessageType;
using protocol::Role;

class SessionRules : public ::testing::Test {
 protected:
  daemon::ServerOptions options() {
    daemon::ServerOptions o;
    o.max_clients = 16;
    return o;
  }
  FakeEngine engine_;
  ServerThread server_{engine_, options()};
};

TEST_F(SessionRules, RequestBeforeHelloIsRefusedAndTheSessionContinues) {
  TestClient c(server_.port());
  const auto id = c.send(protocol::GetStatus{});
  const auto reply = c.reply_to(id);
  ASSERT_EQ(error_code_of(reply), ErrorCode::kHelloRequired);
  EXPECT_EQ(std::get<protocol::ErrorReply>(reply).offending_type, MessageType::kGetStatus);
  EXPECT_EQ(error_code_of(c.request(protocol::MeasureDoorWidth{})), ErrorCode::kHelloRequired);
  EXPECT_EQ(engine_.count(MessageType::kMeasureDoorWidth), 0U);

  const auto welcome = c.hello(Role::kObserver);
  EXPECT_EQ(welcome.granted_role, Role::kObserver);
  EXPECT_NE(welcome.session_id, 0U);
  EXPECT_EQ(welcome.daemon_version.view(), "fake");
  EXPECT_FLOAT_EQ(welcome.loop_rate_hz, 500.0F);
  EXPECT_TRUE(std::holds_alternative<protocol::Status>(c.request(protocol::GetStatus{})));
}

TEST_F(SessionRules, SecondHelloIsAlreadyGreeted) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  EXPECT_EQ(error_code_of(c.request(hello_as(Role::kController))), ErrorCode::kAlreadyGreeted);
  EXPECT_EQ(error_code_of(c.request(protocol::AlignBase{})), ErrorCode::kNotController);
}

TEST_F(SessionRules, HelloWithAnotherMajorVersionIsRefused) {
  TestClient c(server_.port());
  auto hello = hello_as(Role::kController);
  hello.version_major = 7;
  const auto reply = c.request(hello);
  ASSERT_EQ(error_code_of(reply), ErrorCode::kUnsupportedVersion);
  EXPECT_EQ(std::get<protocol::ErrorReply>(reply).field.view(), "version_major");
  EXPECT_EQ(c.hello(Role::kController).granted_role, Role::kController);
}

TEST_F(SessionRules, ObserverCommandsAreRefusedWithoutReachingTheEngine) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  protocol::MeasureDoorPlane plane;
  plane.count = 3;
  for (protocol::Message m :
       {protocol::Message{protocol::MeasureDoorWidth{}},
        protocol::Message{protocol::MeasureHandle{}}, protocol::Message{plane},
        protocol::Message{protocol::SetContactPoint{}}, protocol::Message{protocol::AlignBase{}},
        protocol::Message{protocol::Engage{}}, protocol::Message{protocol::Reset{}}}) {
    const auto reply = c.request(m);
    ASSERT_EQ(error_code_of(reply), ErrorCode::kNotController)
        << protocol::to_string(protocol::type_of(m));
    EXPECT_EQ(std::get<protocol::ErrorReply>(reply).offending_type, protocol::type_of(m));
  }
  EXPECT_TRUE(engine_.commands().empty());
}

TEST_F(SessionRules, StopsAreAcceptedFromAnySessionEvenBeforeHello) {
  TestClient anonymous(server_.port());
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(anonymous.request(protocol::EmergencyStop{})));
  TestClient observer(server_.port());
  observer.hello(Role::kObserver);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(observer.request(protocol::Stop{})));
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(observer.request(protocol::EmergencyStop{})));
  EXPECT_EQ(engine_.count(MessageType::kEmergencyStop), 2U);
  EXPECT_EQ(engine_.count(MessageType::kStop), 1U);
}

TEST_F(SessionRules, ControllerCommandsReachTheEngineWithTheRequestId) {
  TestClient c(server_.port());
  EXPECT_EQ(c.hello(Role::kController).granted_role, Role::kController);
  const auto id = c.send(protocol::AlignBase{}, 777);
  const auto reply = c.reply_to(id);
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(reply));
  EXPECT_EQ(std::get<protocol::Ack>(reply).acknowledged, MessageType::kAlignBase);
  EXPECT_EQ(engine_.count(MessageType::kAlignBase), 1U);
}

TEST_F(SessionRules, ASecondControllerWithoutTakeOverIsBusyAndMayStayAsObserver) {
  TestClient first(server_.port());
  first.hello(Role::kController);
  TestClient second(server_.port());
  const auto reply = second.request(hello_as(Role::kController));
  ASSERT_EQ(error_code_of(reply), ErrorCode::kControllerBusy);
  EXPECT_EQ(std::get<protocol::ErrorReply>(reply).field.view(), "take_over");
  // Still un-greeted: it may say Hello again, as an observer.
  EXPECT_EQ(second.hello(Role::kObserver).granted_role, Role::kObserver);
  EXPECT_EQ(error_code_of(second.request(protocol::AlignBase{})), ErrorCode::kNotController);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(first.request(protocol::AlignBase{})));
}

TEST_F(SessionRules, TakeOverDemotesAndNotifiesThePreviousController) {
  TestClient first(server_.port());
  first.hello(Role::kController);
  TestClient observer(server_.port());
  observer.hello(Role::kObserver);
  const int lost_before = engine_.controller_lost_count();

  TestClient second(server_.port());
  EXPECT_EQ(second.hello(Role::kController, 0, /*take_over=*/true).granted_role, Role::kController);
  EXPECT_GT(engine_.controller_lost_count(), lost_before);  // motion of the old controller stops
  ASSERT_TRUE(first.wait_event(protocol::EventKind::kControlChanged));
  ASSERT_TRUE(observer.wait_event(protocol::EventKind::kControlChanged));
  EXPECT_EQ(error_code_of(first.request(protocol::AlignBase{})), ErrorCode::kNotController);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(second.request(protocol::AlignBase{})));
  EXPECT_EQ(engine_.count(MessageType::kAlignBase), 1U);
}

TEST_F(SessionRules, ControllerDisconnectIsReportedToTheEngineAndTheObservers) {
  TestClient observer(server_.port());
  observer.hello(Role::kObserver);
  {
    TestClient controller(server_.port());
    controller.hello(Role::kController);
    ASSERT_TRUE(observer.wait_event(protocol::EventKind::kControlChanged));  // granted
    controller.close();
  }
  ASSERT_TRUE(eventually([&] { return engine_.controller_lost_count() == 1; }));
  ASSERT_TRUE(observer.wait_event(protocol::EventKind::kControlChanged));  // gone
  // Control is free again: no take-over needed.
  TestClient next(server_.port());
  EXPECT_EQ(next.hello(Role::kController).granted_role, Role::kController);
}

TEST_F(SessionRules, EveryFrameFromTheControllerIsAHeartbeatButObserverFramesAreNot) {
  TestClient observer(server_.port());
  observer.hello(Role::kObserver);
  observer.request(protocol::Ping{});
  EXPECT_EQ(engine_.heartbeats(), 0);
  TestClient controller(server_.port());
  controller.hello(Role::kController);
  const int before = engine_.heartbeats();
  controller.request(protocol::Ping{});
  controller.request(protocol::GetStatus{});
  auto bad = frame_of(protocol::Ping{}, 9);
  bad[18] ^= 0xFF;  // CRC
  controller.send_raw(bad);
  controller.reply_to(9);
  EXPECT_EQ(engine_.heartbeats(), before + 3);
}

TEST_F(SessionRules, PingIsAnsweredWithTheClientTime) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  const auto pong = c.request_as<protocol::Pong>(protocol::Ping{123456789});
  EXPECT_EQ(pong.client_time_ns, 123456789U);
  EXPECT_GT(pong.daemon_time_ns, 0U);
}

TEST_F(SessionRules, StatusCountsSessionsAndTheController) {
  TestClient a(server_.port());
  a.hello(Role::kObserver);
  auto status = a.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_FALSE(status.controller_connected);
  EXPECT_EQ(status.session_count, 1);
  TestClient b(server_.port());
  b.hello(Role::kController);
  status = a.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_TRUE(status.controller_connected);
  EXPECT_EQ(status.session_count, 2);
}

TEST_F(SessionRules, ARepeatedRequestGetsTheOriginalReplyAndExecutesOnce) {
  TestClient c(server_.port());
  c.hello(Role::kController, 0xC0FFEE);
  protocol::Ack first_ack;
  first_ack.acknowledged = MessageType::kMeasureDoorWidth;
  first_ack.state = protocol::ProcedureState::kAwaitingHandle;
  first_ack.body = protocol::SpanAck{0.9, core::RotationDirection::kCounterClockwise};
  engine_.reply_next_with(first_ack);
  const auto a = c.request_as<protocol::Ack>(protocol::MeasureDoorWidth{}, 41);
  const auto b = c.request_as<protocol::Ack>(protocol::MeasureDoorWidth{}, 41);
  EXPECT_EQ(engine_.count(MessageType::kMeasureDoorWidth), 1U);
  ASSERT_TRUE(std::holds_alternative<protocol::SpanAck>(b.body));
  EXPECT_DOUBLE_EQ(std::get<protocol::SpanAck>(b.body).length_m, 0.9);
  EXPECT_EQ(std::get<protocol::SpanAck>(a.body).direction,
            std::get<protocol::SpanAck>(b.body).direction);
  // A new request id executes.
  c.request_as<protocol::Ack>(protocol::MeasureDoorWidth{}, 42);
  EXPECT_EQ(engine_.count(MessageType::kMeasureDoorWidth), 2U);
}

TEST_F(SessionRules, ARepeatedRequestExecutesOnceAcrossAReconnect) {
  {
    TestClient c(server_.port());
    c.hello(Role::kController, 0xBEEF);
    c.request_as<protocol::Ack>(protocol::AlignBase{}, 5);
  }
  TestClient again(server_.port());
  again.hello(Role::kController, 0xBEEF, true);
  const auto reply =
      again.request_as<protocol::Ack>(protocol::AlignBase{}, 5, protocol::kFlagRetransmit);
  EXPECT_EQ(reply.acknowledged, MessageType::kAlignBase);
  EXPECT_EQ(engine_.count(MessageType::kAlignBase), 1U);
  // Another client instance with the same request id is a different request.
  TestClient other(server_.port());
  other.hello(Role::kController, 0xD00D, true);
  other.request_as<protocol::Ack>(protocol::AlignBase{}, 5);
  EXPECT_EQ(engine_.count(MessageType::kAlignBase), 2U);
}

TEST_F(SessionRules, RefusalsAreReplayedButQueueFullIsNot) {
  TestClient c(server_.port());
  c.hello(Role::kController, 0xABC);
  protocol::ErrorReply refused;
  refused.code = ErrorCode::kWidthOutOfRange;
  refused.offending_type = MessageType::kMeasureDoorWidth;
  refused.field = "width_m";
  engine_.reply_next_with(refused);
  EXPECT_EQ(error_code_of(c.request(protocol::MeasureDoorWidth{}, 1)), ErrorCode::kWidthOutOfRange);
  EXPECT_EQ(error_code_of(c.request(protocol::MeasureDoorWidth{}, 1)), ErrorCode::kWidthOutOfRange);
  EXPECT_EQ(engine_.count(MessageType::kMeasureDoorWidth), 1U);

  protocol::ErrorReply full;
  full.code = ErrorCode::kQueueFull;
  full.offending_type = MessageType::kAlignBase;
  engine_.reply_next_with(full);
  EXPECT_EQ(error_code_of(c.request(protocol::AlignBase{}, 2)), ErrorCode::kQueueFull);
  EXPECT_TRUE(
      std::holds_alternative<protocol::Ack>(c.request(protocol::AlignBase{}, 2)));  // retried
  EXPECT_EQ(engine_.count(MessageType::kAlignBase), 2U);
}

TEST_F(SessionRules, WithoutAClientInstanceIdNothingIsDeduplicated) {
  TestClient c(server_.port());
  c.hello(Role::kController, 0);
  c.request_as<protocol::Ack>(protocol::AlignBase{}, 3);
  c.request_as<protocol::Ack>(protocol::AlignBase{}, 3);
  EXPECT_EQ(engine_.count(MessageType::kAlignBase), 2U);
}

TEST_F(SessionRules, RepeatedStopsAlwaysReachTheEngine) {
  TestClient c(server_.port());
  c.hello(Role::kController, 0x51);
  c.request_as<protocol::Ack>(protocol::EmergencyStop{}, 8);
  c.request_as<protocol::Ack>(protocol::EmergencyStop{}, 8);
  EXPECT_EQ(engine_.count(MessageType::kEmergencyStop), 2U);
}

TEST_F(SessionRules, SubscribeSendsTelemetryUntilTurnedOff) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  const auto ack = c.request_as<protocol::Ack>(protocol::Subscribe{200.0F});
  EXPECT_EQ(ack.acknowledged, MessageType::kSubscribe);
  ASSERT_TRUE(c.wait_telemetry(5));
  EXPECT_EQ(c.last_telemetry()->daemon_time_ns, 42U);
  c.request_as<protocol::Ack>(protocol::Subscribe{0.0F});
  // After the Ack of the unsubscribe, no telemetry may follow: Ping's reply comes after anything
  // queued before, so count what arrived by then and check nothing more arrives.
  c.request_as<protocol::Pong>(protocol::Ping{});
  const auto count = c.telemetry_count();
  EXPECT_FALSE(c.wait_telemetry(count + 1, 300ms));
}

TEST_F(SessionRules, SubscribeAboveTheLoopRateIsCappedNotRefused) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(c.request(protocol::Subscribe{1e6F})));
  EXPECT_TRUE(c.wait_telemetry(3));
}

TEST_F(SessionRules, NegativeOrNonFiniteRatesAreRefused) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  const auto reply = c.request(protocol::Subscribe{-1.0F});
  ASSERT_EQ(error_code_of(reply), ErrorCode::kRateLimited);
  EXPECT_EQ(std::get<protocol::ErrorReply>(reply).field.view(), "telemetry_rate_hz");
  // Infinity: refused by the decoder (NON_FINITE_NUMBER) or the session (RATE_LIMITED).
  const auto inf =
      error_code_of(c.request(protocol::Subscribe{std::numeric_limits<float>::infinity()}));
  EXPECT_TRUE(inf == ErrorCode::kRateLimited || inf == ErrorCode::kNonFiniteNumber)
      << to_string(inf);
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(c.request(protocol::Ping{})));
}

TEST_F(SessionRules, EngineEventsReachEveryGreetedSession) {
  TestClient a(server_.port());
  a.hello(Role::kObserver);
  TestClient b(server_.port());
  b.hello(Role::kController);
  protocol::Event event;
  event.kind = protocol::EventKind::kFaultLatched;
  event.fault = ErrorCode::kDeadman;
  engine_.emit(event);
  auto ea = a.wait_event(protocol::EventKind::kFaultLatched);
  auto eb = b.wait_event(protocol::EventKind::kFaultLatched);
  ASSERT_TRUE(ea && eb);
  EXPECT_EQ(ea->fault, ErrorCode::kDeadman);
  EXPECT_EQ(eb->fault, ErrorCode::kDeadman);
}

TEST_F(SessionRules, AHostMessageTypeFromTheHostIsRefused) {
  TestClient c(server_.port());
  c.hello(Role::kObserver);
  const auto reply = c.request(protocol::Pong{});
  EXPECT_EQ(error_code_of(reply), ErrorCode::kUnknownMessageType);
}

// Durable Acks: a command's Ack waits until its save settled; the session's later replies queue
// behind it (request order), its Stop is executed at once; other sessions are not delayed.
TEST_F(SessionRules, AHeldAckKeepsRequestOrderAndDelaysOnlyItsSession) {
  engine_.persisting(true);
  TestClient controller(server_.port());
  controller.hello(Role::kController);
  TestClient observer(server_.port());
  observer.hello(Role::kObserver);

  auto bytes = frame_of(protocol::MeasureDoorWidth{}, 10);
  for (const auto& f : {frame_of(protocol::Ping{7}, 11), frame_of(protocol::Stop{}, 12)})
    bytes.insert(bytes.end(), f.begin(), f.end());
  controller.send_raw(bytes);
  ASSERT_TRUE(eventually([&] { return engine_.count(MessageType::kStop) == 1; }));  // executed
  // The other session is served while the controller's save is pending, its e-stop included.
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(observer.request(protocol::Ping{1})));
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(observer.request(protocol::EmergencyStop{})));
  // Nothing for the controller until its save settles.
  const auto next_reply = [&](std::chrono::milliseconds timeout) -> std::optional<std::uint32_t> {
    for (;;) {  // events (control_changed) are not replies
      auto outcome = controller.next(timeout);
      if (!outcome) return std::nullopt;
      if (outcome->kind == protocol::StreamDecoder::Kind::kMessage &&
          outcome->envelope.request_id != 0) {
        return outcome->envelope.request_id;
      }
    }
  };
  EXPECT_FALSE(next_reply(300ms).has_value());
  engine_.settle();
  std::vector<std::uint32_t> order;
  for (int i = 0; i < 3; ++i) {
    auto id = next_reply(20s);
    ASSERT_TRUE(id);
    order.push_back(*id);
  }
  EXPECT_EQ(order, (std::vector<std::uint32_t>{10, 11, 12}));
  // Nothing held any more: replies flow at once again.
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(controller.request(protocol::Ping{2})));
}

}  // namespace
}  // namespace ajar::test
