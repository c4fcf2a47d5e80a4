// What a client written from docs/protocol.md alone relies on (issue 24, "The spec"), end to end
// over loopback on mock drivers: the reply to a command comes before the events it causes (6.6),
// and every accepted motion — one of zero counts too — is opened and closed by events (5.7, 5.19).
#include <gtest/gtest.h>

#include "e2e_fixture.hpp"

namespace ajar::test {
namespace {

using protocol::EventKind;
using protocol::ProcedureState;
using protocol::Role;

class EndToEndSpecOrder : public EndToEndOnMock {};

// Sends `request` and returns its reply after checking that no event arrived before it.
protocol::Message reply_before_events(TestClient& client, const protocol::Message& request) {
  (void)client.request(protocol::Ping{0});  // what was sent before the Pong is read and kept
  client.events().clear();
  protocol::Message reply = client.request(request);
  EXPECT_TRUE(client.events().empty())
      << client.events().size() << " event(s) arrived before the reply to "
      << protocol::to_string(protocol::type_of(request)) << ", the first "
      << protocol::to_string(client.events().front().kind) << " ("
      << client.events().front().detail.view() << ")";
  return reply;
}

// Waits for an event of `kind`, pinging (the deadman) while it waits.
std::optional<protocol::Event> wait_pinging(TestClient& client, EventKind kind) {
  for (int i = 0; i < 300; ++i) {
    if (auto e = client.wait_event(kind, std::chrono::milliseconds(100))) return e;
    (void)client.request(protocol::Ping{1});
  }
  return std::nullopt;
}

TEST_F(EndToEndSpecOrder, EveryAckComesBeforeTheEventsItCauses) {
  InProcessDaemon d(config(10.0));
  TestClient controller(d.port());
  controller.hello(Role::kController, 0x5151);
  // Measurements: their Ack is held for the save; the state_changed they cause waits behind it.
  for (const protocol::Message& m :
       {protocol::Message{good_width()}, protocol::Message{good_handle()},
        protocol::Message{plane_at_yaw(0.1)}}) {
    const ProcedureState state = ack_state(reply_before_events(controller, m));
    const auto changed = controller.wait_event(EventKind::kStateChanged);
    ASSERT_TRUE(changed);
    EXPECT_EQ(changed->state, state);
  }
  // AlignBase: Ack(aligning), then motion_started, then motion_finished.
  ASSERT_EQ(ack_state(reply_before_events(controller, protocol::AlignBase{})),
            ProcedureState::kAligning);
  ASSERT_TRUE(controller.wait_event(EventKind::kMotionStarted));
  ASSERT_TRUE(wait_pinging(controller, EventKind::kMotionFinished));
  ASSERT_EQ(ack_state(reply_before_events(controller, good_contact())),
            ProcedureState::kReadyToEngage);
  ASSERT_EQ(ack_state(reply_before_events(controller, protocol::Engage{})),
            ProcedureState::kEngaging);
  ASSERT_TRUE(controller.wait_event(EventKind::kMotionStarted));
  ASSERT_TRUE(wait_pinging(controller, EventKind::kMotionFinished));
}

TEST_F(EndToEndSpecOrder, AnApproachAndAJogAreAcknowledgedBeforeTheirMotionStarted) {
  InProcessDaemon d(config(10.0));
  TestClient controller(d.port());
  controller.hello(Role::kController);
  ASSERT_EQ(ack_state(controller.request(good_width())), ProcedureState::kAwaitingHandle);
  const auto status = controller.request_as<protocol::Status>(protocol::GetStatus{});
  ASSERT_TRUE(status.door.has_distance);
  const protocol::Message approach =
      reply_before_events(controller, protocol::Approach{status.door.distance_m - 0.05});
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(approach)) << TestClient::describe(approach);
  ASSERT_TRUE(controller.wait_event(EventKind::kMotionStarted));
  ASSERT_TRUE(wait_pinging(controller, EventKind::kMotionFinished));

  const protocol::Message drive = reply_before_events(controller, protocol::Drive{-0.05, 0.0});
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(drive)) << TestClient::describe(drive);
  ASSERT_TRUE(controller.wait_event(EventKind::kMotionStarted));
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(controller.request(protocol::Drive{0, 0})));
  ASSERT_TRUE(wait_pinging(controller, EventKind::kMotionFinished));
}

// A plane already square to the base: AlignBase is acknowledged `aligned` and nothing turns; an
// Approach to where the base already is: zero counts. Each is still an accepted motion, closed by
// motion_finished (before: no event but state_changed, so a client waiting for completion hung).
TEST_F(EndToEndSpecOrder, AZeroCountAlignmentAndApproachAreClosedByMotionFinished) {
  InProcessDaemon d(config(10.0));
  TestClient controller(d.port());
  controller.hello(Role::kController);
  measure_door(controller, 0.0);
  ASSERT_EQ(ack_state(reply_before_events(controller, protocol::AlignBase{})),
            ProcedureState::kAligned);
  const auto started = controller.wait_event(EventKind::kMotionStarted);
  ASSERT_TRUE(started);
  const auto finished = controller.wait_event(EventKind::kMotionFinished);
  ASSERT_TRUE(finished);
  EXPECT_EQ(finished->state, ProcedureState::kAligned);

  const auto status = controller.request_as<protocol::Status>(protocol::GetStatus{});
  ASSERT_TRUE(status.door.has_distance);
  const protocol::Message reply =
      reply_before_events(controller, protocol::Approach{status.door.distance_m});
  const auto* ack = std::get_if<protocol::Ack>(&reply);
  ASSERT_NE(ack, nullptr) << TestClient::describe(reply);
  const auto& body = std::get<protocol::ApproachAck>(ack->body);
  ASSERT_EQ(body.left_counts, 0);
  ASSERT_EQ(body.right_counts, 0);
  ASSERT_TRUE(controller.wait_event(EventKind::kMotionStarted));
  ASSERT_TRUE(controller.wait_event(EventKind::kMotionFinished));
  // Nothing moved: the next motion is accepted at once.
  EXPECT_EQ(ack_state(controller.request(protocol::Approach{status.door.distance_m})),
            ProcedureState::kAligned);
}

// Before: the new controller was greeted before the old one's motion was stopped, so the events of
// that stop (fault_latched DEADMAN, ...) reached it before its own Welcome.
TEST_F(EndToEndSpecOrder, ATakeOverDuringMotionIsWelcomedBeforeTheOldControllersStop) {
  InProcessDaemon d(config(1.0));  // real time: the alignment is still turning
  TestClient old_controller(d.port());
  old_controller.hello(Role::kController);
  measure_door(old_controller, 0.6);
  ASSERT_EQ(ack_state(old_controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  TestClient next(d.port());
  const std::uint32_t id = next.send(hello_as(Role::kController, 0, true));
  const auto first = next.next();
  ASSERT_TRUE(first && first->kind == protocol::StreamDecoder::Kind::kMessage);
  ASSERT_TRUE(std::holds_alternative<protocol::Welcome>(first->envelope.message))
      << "the first frame is " << protocol::to_string(protocol::type_of(first->envelope.message));
  EXPECT_EQ(first->envelope.request_id, id);
  const auto second = next.next();
  ASSERT_TRUE(second && second->kind == protocol::StreamDecoder::Kind::kMessage);
  const auto* changed = std::get_if<protocol::Event>(&second->envelope.message);
  ASSERT_NE(changed, nullptr);
  EXPECT_EQ(changed->kind, EventKind::kControlChanged);
  const auto fault = next.wait_event(EventKind::kFaultLatched);
  ASSERT_TRUE(fault);
  EXPECT_EQ(fault->fault, ErrorCode::kDeadman);
}

// An observer's take_over is ignored (6.2): granted observer, the controller keeps control.
TEST_F(EndToEndSpecOrder, AnObserverHelloWithTakeOverLeavesTheControllerAlone) {
  InProcessDaemon d(config(10.0));
  TestClient controller(d.port());
  controller.hello(Role::kController);
  TestClient observer(d.port());
  EXPECT_EQ(observer.hello(Role::kObserver, 0, true).granted_role, Role::kObserver);
  EXPECT_EQ(ack_state(controller.request(good_width())), ProcedureState::kAwaitingHandle);
}

}  // namespace
}  // namespace ajar::test
