// End to end over loopback with the real protocol: the server and the real engine on mock and on
// simulated drivers. The whole procedure, error paths, deadman on a killed controller, emergency
// stop, exactly-once across reconnects, restart with restored state, 256 observers, malformed
// frames and a slow reader next to a working controller.
#include <memory>

#include <gtest/gtest.h>

#include "e2e_fixture.hpp"

namespace ajar::test {
namespace {

using protocol::EventKind;
using protocol::MessageType;
using protocol::ProcedureState;
using protocol::Role;

class EndToEnd : public EndToEndTest {};

TEST_P(EndToEnd, TheWholeProcedureWithAnObserverWatching) {
  InProcessDaemon d(config());
  TestClient observer(d.port());
  observer.hello(Role::kObserver);
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(observer.request(protocol::Subscribe{50})));
  TestClient controller(d.port());
  ASSERT_EQ(controller.hello(Role::kController, 0x1001).granted_role, Role::kController);

  run_procedure(controller);

  EXPECT_TRUE(observer.wait_event(EventKind::kMotionStarted));
  EXPECT_TRUE(observer.wait_event(EventKind::kMotionFinished));
  EXPECT_TRUE(observer.wait_event(EventKind::kStateChanged, 20s, ProcedureState::kEngaged));
  EXPECT_TRUE(observer.wait_telemetry(3));
  const auto status = observer.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_EQ(status.state, ProcedureState::kEngaged);
  EXPECT_TRUE(status.has_width && status.has_handle && status.has_plane && status.has_contact);
  EXPECT_NEAR(status.width.length_m, 0.85, 1e-6);
  EXPECT_TRUE(status.controller_connected);
  EXPECT_EQ(status.session_count, 2);
}

TEST_P(EndToEnd, ControllerKilledMidAlignmentStopsTheMotionAndLatchesAFault) {
  InProcessDaemon d(config(1.0));
  TestClient observer(d.port());
  observer.hello(Role::kObserver);
  observer.request_as<protocol::Ack>(protocol::Subscribe{100});
  {
    TestClient controller(d.port());
    controller.hello(Role::kController);
    measure_door(controller, 0.6);
    ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
    ASSERT_TRUE(observer.wait_event(EventKind::kMotionStarted));
    controller.close();  // the operator console dies mid-alignment
  }
  const auto fault = observer.wait_event(EventKind::kFaultLatched);
  ASSERT_TRUE(fault);
  EXPECT_EQ(fault->fault, ErrorCode::kDeadman);
  EXPECT_TRUE(observer.wait_event(EventKind::kControlChanged));
  const auto status = wait_for_state(observer, ProcedureState::kFault);
  EXPECT_EQ(status.latched_fault, ErrorCode::kDeadman);
  EXPECT_FALSE(status.controller_connected);
  // The wheels come to rest.
  ASSERT_TRUE(eventually([&] {
    const auto before = observer.telemetry_count();
    return observer.wait_telemetry(before + 1) && !observer.last_telemetry()->moving;
  }));
  // Nothing moves until a controller resets explicitly.
  TestClient next(d.port());
  next.hello(Role::kController);
  EXPECT_EQ(error_code_of(next.request(protocol::AlignBase{})), ErrorCode::kFaultLatched);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(next.request(protocol::Reset{})));
  EXPECT_NE(next.request_as<protocol::Status>(protocol::GetStatus{}).state, ProcedureState::kFault);
}

TEST_P(EndToEnd, EmergencyStopFromAnObserverLatchesUntilReset) {
  InProcessDaemon d(config(1.0));
  TestClient controller(d.port());
  controller.hello(Role::kController);
  TestClient observer(d.port());
  observer.hello(Role::kObserver);
  measure_door(controller, 0.6);
  ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(observer.request(protocol::EmergencyStop{})));
  const auto fault = observer.wait_event(EventKind::kFaultLatched);
  ASSERT_TRUE(fault);
  EXPECT_EQ(fault->fault, ErrorCode::kEmergencyStopped);
  const auto status = wait_for_state(controller, ProcedureState::kFault);
  EXPECT_EQ(status.latched_fault, ErrorCode::kEmergencyStopped);
  EXPECT_EQ(error_code_of(controller.request(protocol::AlignBase{})), ErrorCode::kFaultLatched);
  EXPECT_EQ(error_code_of(observer.request(protocol::Reset{})), ErrorCode::kNotController);
  EXPECT_TRUE(std::holds_alternative<protocol::Ack>(controller.request(protocol::Reset{})));
  EXPECT_TRUE(observer.wait_event(EventKind::kFaultCleared));
}

TEST_P(EndToEnd, ADuplicatedRequestExecutesOnceAlsoAcrossAReconnect) {
  InProcessDaemon d(config());
  constexpr std::uint64_t kInstance = 0xA11CE;
  protocol::Ack first;
  {
    TestClient controller(d.port());
    controller.hello(Role::kController, kInstance);
    measure_door(controller);
    first = controller.request_as<protocol::Ack>(protocol::AlignBase{}, 500);
    ASSERT_EQ(first.state, ProcedureState::kAligning);
    // The same request again on the same connection: the original reply, no second motion.
    const auto again = controller.request_as<protocol::Ack>(protocol::AlignBase{}, 500);
    EXPECT_EQ(again.state, ProcedureState::kAligning);
    wait_for_state(controller, ProcedureState::kAligned);
  }
  TestClient observer(d.port());
  observer.hello(Role::kObserver);
  const double yaw_after =
      observer.request_as<protocol::Status>(protocol::GetStatus{}).base_yaw_odometry_rad;

  TestClient reconnected(d.port());
  reconnected.hello(Role::kController, kInstance, true);
  const auto replay =
      reconnected.request_as<protocol::Ack>(protocol::AlignBase{}, 500, protocol::kFlagRetransmit);
  EXPECT_EQ(replay.acknowledged, MessageType::kAlignBase);
  EXPECT_EQ(replay.state, ProcedureState::kAligning);  // the original reply, not a new execution
  const auto status = reconnected.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_EQ(status.state, ProcedureState::kAligned);
  EXPECT_DOUBLE_EQ(status.base_yaw_odometry_rad, yaw_after);
  EXPECT_FALSE(observer.wait_event(EventKind::kMotionStarted, 300ms));
}

TEST_P(EndToEnd, RestartRestoresTheParametersAndNothingMoves) {
  {
    InProcessDaemon d(config());
    TestClient controller(d.port());
    controller.hello(Role::kController);
    measure_door(controller);
  }  // shutdown persists
  InProcessDaemon again(config());
  TestClient observer(again.port());
  observer.hello(Role::kObserver);
  const auto status = observer.request_as<protocol::Status>(protocol::GetStatus{});
  EXPECT_TRUE(status.restored_from_disk);
  EXPECT_TRUE(status.has_width && status.has_handle && status.has_plane);
  EXPECT_FALSE(status.has_contact);
  EXPECT_NEAR(status.width.length_m, 0.85, 1e-9);
  EXPECT_NEAR(status.handle.length_m, 0.12, 1e-9);
  EXPECT_EQ(status.state, ProcedureState::kReadyToAlign);
  observer.request_as<protocol::Ack>(protocol::Subscribe{50});
  ASSERT_TRUE(observer.wait_telemetry(3));
  EXPECT_FALSE(observer.last_telemetry()->moving);
}

INSTANTIATE_TEST_SUITE_P(Drivers, EndToEnd, kE2eDriverKinds, driver_name);

// The rest on mock drivers (the network side does not depend on the driver kind).
class EndToEndMock : public EndToEndOnMock {};

TEST_F(EndToEndMock, EveryErrorPathAnswersWithCodeAndFieldAndNothingMoves) {
  InProcessDaemon d(config(20.0));
  TestClient observer(d.port());
  EXPECT_EQ(error_code_of(observer.request(protocol::GetStatus{})), ErrorCode::kHelloRequired);
  observer.hello(Role::kObserver);
  EXPECT_EQ(error_code_of(observer.request(hello_as(Role::kObserver))), ErrorCode::kAlreadyGreeted);
  EXPECT_EQ(error_code_of(observer.request(good_width())), ErrorCode::kNotController);
  EXPECT_EQ(error_code_of(observer.request(protocol::Subscribe{-5})), ErrorCode::kRateLimited);
  observer.request_as<protocol::Ack>(protocol::Subscribe{100});

  TestClient controller(d.port());
  controller.hello(Role::kController);
  TestClient rival(d.port());
  EXPECT_EQ(error_code_of(rival.request(hello_as(Role::kController))), ErrorCode::kControllerBusy);

  // Out of order: names what is missing.
  EXPECT_EQ(error_code_of(controller.request(protocol::AlignBase{})), ErrorCode::kMissingDoorWidth);
  // Validation refusals name the field.
  auto refused = controller.request(too_wide());
  ASSERT_EQ(error_code_of(refused), ErrorCode::kWidthOutOfRange);
  EXPECT_EQ(std::get<protocol::ErrorReply>(refused).offending_type, MessageType::kMeasureDoorWidth);
  auto nan_width = good_width();
  nan_width.p2_moving_edge.position_m.y() = std::numeric_limits<double>::quiet_NaN();
  refused = controller.request(nan_width);
  const auto nan_code = error_code_of(refused);
  EXPECT_TRUE(nan_code == ErrorCode::kNonFiniteNumber || nan_code == ErrorCode::kNonFinite)
      << to_string(nan_code);
  EXPECT_FALSE(std::get<protocol::ErrorReply>(refused).field.view().empty());

  ASSERT_EQ(ack_state(controller.request(good_width())), ProcedureState::kAwaitingHandle);
  ASSERT_EQ(ack_state(controller.request(good_handle())), ProcedureState::kAwaitingPlane);
  refused = controller.request(collinear_plane());
  ASSERT_EQ(error_code_of(refused), ErrorCode::kPointsCollinear);
  EXPECT_FALSE(std::get<protocol::ErrorReply>(refused).field.view().empty());
  EXPECT_EQ(error_code_of(controller.request(protocol::Engage{})), ErrorCode::kMissingPlane);
  ASSERT_EQ(ack_state(controller.request(plane_at_yaw(0.1))), ProcedureState::kReadyToAlign);
  EXPECT_EQ(error_code_of(controller.request(good_contact())), ErrorCode::kNotAligned);

  // Nothing moved on any refusal.
  ASSERT_TRUE(observer.wait_telemetry(observer.telemetry_count() + 2));
  EXPECT_FALSE(observer.last_telemetry()->moving);
  EXPECT_FALSE(observer.wait_event(EventKind::kMotionStarted, 100ms));

  ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  wait_for_state(controller, ProcedureState::kAligned);
  refused = controller.request(unreachable_contact());
  ASSERT_EQ(error_code_of(refused), ErrorCode::kOutOfReach);
  EXPECT_FALSE(std::get<protocol::ErrorReply>(refused).field.view().empty());
  EXPECT_EQ(error_code_of(controller.request(protocol::Engage{})), ErrorCode::kMissingContactPoint);
}

TEST_F(EndToEndMock, TwoHundredFiftySixObserversWhileAControllerCompletesTheProcedure) {
  auto c = config(20.0);
  c.network.max_clients = 300;
  InProcessDaemon d(c);
  std::vector<std::unique_ptr<TestClient>> observers;
  for (int i = 0; i < 256; ++i) {
    observers.push_back(std::make_unique<TestClient>(d.port()));
    observers.back()->hello(Role::kObserver);
    observers.back()->send(protocol::Subscribe{10});
  }
  TestClient controller(d.port());
  controller.hello(Role::kController);
  run_procedure(controller);
  for (auto& o : observers) {
    ASSERT_TRUE(o->wait_event(EventKind::kStateChanged, 30s, ProcedureState::kEngaged));
    ASSERT_TRUE(o->wait_telemetry(1));
  }
}

TEST_F(EndToEndMock, MalformedFramesAndASlowReaderLeaveTheControllerUntouched) {
  auto c = config(20.0);
  c.network.send_queue_frames = 16;
  InProcessDaemon d(c);
  TestClient controller(d.port());
  controller.hello(Role::kController);
  measure_door(controller);

  // Bad CRC and unknown type: answered, session continues.
  TestClient noisy(d.port());
  noisy.hello(Role::kObserver);
  auto bad_crc = frame_of(protocol::Ping{}, 71);
  bad_crc[20] ^= 0x5A;
  noisy.send_raw(bad_crc);
  EXPECT_EQ(error_code_of(noisy.reply_to(71)), ErrorCode::kCrcMismatch);
  auto unknown = frame_of(protocol::Ping{}, 72);
  put_u16(unknown, 6, 0x0777);
  fix_crc(unknown);
  noisy.send_raw(unknown);
  EXPECT_EQ(error_code_of(noisy.reply_to(72)), ErrorCode::kUnknownMessageType);
  // Bad magic and oversize: answered, then that session (only) is closed.
  TestClient garbage(d.port());
  garbage.hello(Role::kObserver);
  garbage.send_raw(std::vector<std::uint8_t>(64, 0xEE));
  EXPECT_TRUE(garbage.wait_closed());
  TestClient huge(d.port());
  huge.hello(Role::kObserver);
  auto oversize = frame_of(protocol::Ping{}, 73);
  put_u32(oversize, 14, 50'000);
  huge.send_raw(oversize);
  EXPECT_EQ(error_code_of(huge.reply_to(73)), ErrorCode::kPayloadTooLarge);
  EXPECT_TRUE(huge.wait_closed());
  // A reader that stops reading is dropped.
  TestClient lazy(d.port(), 4096);
  lazy.hello(Role::kObserver);
  const auto request = frame_of(protocol::GetStatus{}, 1);
  std::vector<std::uint8_t> burst;
  for (int i = 0; i < 256; ++i)
    burst.insert(burst.end(), request.begin(), request.end());
  for (int i = 0; i < 20000 && lazy.send_raw(burst); ++i) {
  }
  EXPECT_TRUE(lazy.wait_closed());

  // The controller never noticed.
  ASSERT_EQ(ack_state(controller.request(protocol::AlignBase{})), ProcedureState::kAligning);
  EXPECT_EQ(wait_for_state(controller, ProcedureState::kAligned).state, ProcedureState::kAligned);
  EXPECT_TRUE(std::holds_alternative<protocol::Pong>(noisy.request(protocol::Ping{})));
}

}  // namespace
}  // namespace ajar::test
