// The engine over fake drivers: the procedure end to end, refusals that move nothing, stops,
// emergency stops, resets, the deadman, faults from the card and the arm.
#include <gtest/gtest.h>

#include "fake_engine_fixture.hpp"

namespace ajar::testing {
namespace {

using protocol::EventKind;
using protocol::ProcedureState;

TEST_F(EngineTest, RunsTheWholeProcedure) {
  start();
  EXPECT_TRUE(engine->control_loop_healthy() ||
              wait_for([&] { return engine->control_loop_healthy(); }));
  auto width = send(good_width());
  expect_ack(width, ProcedureState::kAwaitingHandle);
  const auto& span = std::get<protocol::SpanAck>(std::get<protocol::Ack>(width).body);
  EXPECT_NEAR(span.length_m, 0.85, 1e-9);
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  auto plane_reply = send(plane_at_yaw(0.1));
  expect_ack(plane_reply, ProcedureState::kReadyToAlign);
  const auto plane = std::get<protocol::PlaneAck>(std::get<protocol::Ack>(plane_reply).body);
  EXPECT_EQ(move_calls(), 0);

  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  ASSERT_TRUE(wait_for_state(ProcedureState::kAligned));
  const auto log = card->log_from(0);
  ASSERT_FALSE(log.empty());
  const auto moves = log.back().moves;
  ASSERT_EQ(moves.size(), 2U);
  EXPECT_EQ(moves[0].axis, config.base.left.card_axis);
  EXPECT_EQ(moves[0].distance_counts, plane.left_counts);
  EXPECT_EQ(moves[1].axis, config.base.right.card_axis);
  EXPECT_EQ(moves[1].distance_counts, plane.right_counts);
  EXPECT_EQ(move_calls(), 1);
  EXPECT_TRUE(saw_event(EventKind::kMotionStarted));
  EXPECT_TRUE(saw_event(EventKind::kMotionFinished));
  EXPECT_NE(engine->status().base_yaw_odometry_rad, 0.0);

  auto contact = send(good_contact());
  expect_ack(contact, ProcedureState::kReadyToEngage);
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
  const auto tasks = arm->tasks();
  ASSERT_EQ(tasks.size(), 1U);
  EXPECT_NEAR(tasks[0].door_width_m, 0.85, 1e-9);
  EXPECT_NEAR(tasks[0].handle_length_m, 0.12, 1e-9);
  EXPECT_TRUE(tasks[0].contact_base_m.isApprox(
      std::get<protocol::ContactAck>(std::get<protocol::Ack>(contact).body).contact_base_m));
  arm->set_phase(drivers::ArmPhase::kDone);
  ASSERT_TRUE(wait_for_state(ProcedureState::kEngaged));

  const auto status = engine->status();
  EXPECT_TRUE(status.has_width && status.has_handle && status.has_plane && status.has_contact);
  EXPECT_EQ(status.latched_fault, ErrorCode::kOk);
  EXPECT_EQ(status.card, protocol::DriverState::kActive);
  EXPECT_EQ(status.arm, protocol::DriverState::kActive);
  EXPECT_FALSE(status.restored_from_disk);
  EXPECT_GT(engine->telemetry().loop.cycles + status.loop.cycles, 0U);

  int state_events = 0;
  for (const auto& e : events)
    state_events += e.kind == EventKind::kStateChanged ? 1 : 0;
  EXPECT_GE(state_events, 8);  // one per transition
}

TEST_F(EngineTest, RefusalsNameTheProblemAndMoveNothing) {
  start();
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kMissingDoorWidth);
  expect_refused(send(good_handle()), ErrorCode::kMissingDoorWidth);
  expect_refused(send(too_wide()), ErrorCode::kWidthOutOfRange, "width_m");
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
  expect_refused(send(plane_at_yaw(0.1)), ErrorCode::kMissingHandle);
  expect_ack(send(good_handle()), ProcedureState::kAwaitingPlane);
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kMissingPlane);
  expect_refused(send(collinear_plane()), ErrorCode::kPointsCollinear);
  expect_refused(send(protocol::Engage{}), ErrorCode::kMissingPlane);
  expect_ack(send(plane_at_yaw(0.1)), ProcedureState::kReadyToAlign);
  auto r = send(good_contact());
  expect_refused(r, ErrorCode::kNotAligned);
  EXPECT_EQ(std::get<protocol::ErrorReply>(r).message.view(), "align the base first");
  EXPECT_EQ(std::get<protocol::ErrorReply>(r).offending_type,
            protocol::MessageType::kSetContactPoint);
  expect_refused(send(protocol::Engage{}), ErrorCode::kNotAligned);
  // Refusals changed nothing and moved nothing.
  for (int i = 0; i < 20; ++i)
    engine->poll();
  EXPECT_EQ(engine->status().state, ProcedureState::kReadyToAlign);
  EXPECT_EQ(move_calls(), 0);
  EXPECT_TRUE(arm->tasks().empty());
}

TEST_F(EngineTest, MotionCommandsWhileAligningAreRefused) {
  start();
  walk_to(ProcedureState::kAligning);
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kMotionInProgress);
  expect_refused(send(protocol::Engage{}), ErrorCode::kMotionInProgress);
  expect_refused(send(good_width()), ErrorCode::kMotionInProgress);
  EXPECT_EQ(move_calls(), 1);
}

TEST_F(EngineTest, StopDuringAlignmentStopsSmoothlyWithoutFault) {
  start();
  walk_to(ProcedureState::kAligning);
  ASSERT_TRUE(wait_for([&] { return move_calls() == 1; }));
  expect_ack(send(protocol::Stop{}), ProcedureState::kReadyToAlign);
  ASSERT_TRUE(wait_for([&] { return saw_event(EventKind::kMotionStopped); }));
  EXPECT_GE(card->calls(drivers::CardCall::kSmoothStop), 1U);
  EXPECT_EQ(card->calls(drivers::CardCall::kEmergencyStop), 0U);
  EXPECT_GE(arm->stops(), 1U);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  // The base turned by an unknown part: the plane must be measured again.
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kMissingPlane);
  expect_ack(send(plane_at_yaw(0.05)), ProcedureState::kReadyToAlign);  // this one runs
  expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
  EXPECT_TRUE(wait_for_state(ProcedureState::kAligned));
}

// Stop, EmergencyStop and Reset are accepted in every state.
class EveryState : public EngineTest, public ::testing::WithParamInterface<ProcedureState> {
 protected:
  // Where a Stop (or EmergencyStop + Reset) leaves the procedure: an interrupted motion steps
  // back to before it; every other state stays.
  static ProcedureState state_after_interruption(ProcedureState s) {
    if (s == ProcedureState::kAligning) return ProcedureState::kReadyToAlign;
    if (s == ProcedureState::kEngaging) return ProcedureState::kReadyToEngage;
    return s;
  }
};

TEST_P(EveryState, StopIsAcceptedAndLatchesNothing) {
  start();
  walk_to(GetParam());
  const auto reply = send(protocol::Stop{});
  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(reply));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  EXPECT_EQ(engine->status().state, state_after_interruption(GetParam()));
}

TEST_P(EveryState, EmergencyStopLatchesAndResetClears) {
  start();
  walk_to(GetParam());
  const int moves_before = move_calls();
  expect_ack(send(protocol::EmergencyStop{}), ProcedureState::kFault);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kEmergencyStopped);
  EXPECT_TRUE(saw_event(EventKind::kFaultLatched, ErrorCode::kEmergencyStopped));
  EXPECT_GE(arm->stops(), 1U);
  ASSERT_TRUE(wait_for([&] { return card->calls(drivers::CardCall::kEmergencyStop) >= 1; }));
  // Nothing starts while the fault is latched.
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kFaultLatched);
  expect_refused(send(protocol::Engage{}), ErrorCode::kFaultLatched);
  expect_refused(send(good_width()), ErrorCode::kFaultLatched);
  EXPECT_EQ(move_calls(), moves_before);

  ASSERT_TRUE(std::holds_alternative<protocol::Ack>(send(protocol::Reset{})));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  EXPECT_TRUE(saw_event(EventKind::kFaultCleared));
  const ProcedureState after = engine->status().state;
  EXPECT_EQ(after, state_after_interruption(GetParam()));
  // The loop recovered too: a fresh alignment runs (from any state with a plane).
  if (engine->status().has_plane && after == ProcedureState::kReadyToAlign) {
    // The wheels come to rest under the loop's supervision before a new motion is accepted.
    if (GetParam() == ProcedureState::kAligning) {
      ASSERT_TRUE(wait_for([&] { return saw_event(EventKind::kMotionStopped); }));
    }
    expect_ack(send(plane_at_yaw(0.05)), ProcedureState::kReadyToAlign);
    expect_ack(send(protocol::AlignBase{}), ProcedureState::kAligning);
    EXPECT_TRUE(wait_for_state(ProcedureState::kAligned));
  }
}

TEST_P(EveryState, ResetWithClearParametersStartsOver) {
  start();
  walk_to(GetParam());
  expect_ack(send(protocol::Reset{true}), ProcedureState::kAwaitingWidth);
  const auto s = engine->status();
  EXPECT_FALSE(s.has_width || s.has_handle || s.has_plane || s.has_contact);
  expect_ack(send(good_width()), ProcedureState::kAwaitingHandle);
}

INSTANTIATE_TEST_SUITE_P(Engine, EveryState,
                         ::testing::Values(ProcedureState::kAwaitingWidth,
                                           ProcedureState::kAwaitingHandle,
                                           ProcedureState::kAwaitingPlane,
                                           ProcedureState::kReadyToAlign, ProcedureState::kAligning,
                                           ProcedureState::kAligned, ProcedureState::kReadyToEngage,
                                           ProcedureState::kEngaging, ProcedureState::kEngaged),
                         [](const ::testing::TestParamInfo<ProcedureState>& param_info) {
                           return std::string(protocol::to_string(param_info.param));
                         });

TEST_F(EngineTest, DeadmanStopsASilentControllerAndLatches) {
  config.safety.deadman_timeout_s = 0.05;
  start();
  walk_to(ProcedureState::kAligning);  // the fake never finishes; the test never heartbeats again
  ASSERT_TRUE(wait_for_state(ProcedureState::kFault));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kDeadman);
  EXPECT_TRUE(saw_event(EventKind::kFaultLatched, ErrorCode::kDeadman));
  ASSERT_TRUE(wait_for([&] { return saw_event(EventKind::kMotionStopped); }));
  EXPECT_GE(card->calls(drivers::CardCall::kSmoothStop), 1U);
  EXPECT_GE(arm->stops(), 1U);
}

TEST_F(EngineTest, DeadmanWatchesTheArmToo) {
  config.safety.deadman_timeout_s = 0.05;
  start();
  walk_to(ProcedureState::kEngaging);
  ASSERT_TRUE(wait_for_state(ProcedureState::kFault));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kDeadman);
  EXPECT_GE(arm->stops(), 1U);
}

TEST_F(EngineTest, ControllerLostDuringAlignmentStopsAtOnce) {
  start();
  walk_to(ProcedureState::kAligning);
  engine->controller_lost();
  EXPECT_EQ(engine->status().state, ProcedureState::kFault);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kDeadman);
  EXPECT_TRUE(saw_event(EventKind::kFaultLatched, ErrorCode::kDeadman));
  ASSERT_TRUE(wait_for([&] { return saw_event(EventKind::kMotionStopped); }));
  EXPECT_GE(card->calls(drivers::CardCall::kSmoothStop), 1U);
}

TEST_F(EngineTest, ControllerLostWhileIdleChangesNothing) {
  start();
  walk_to(ProcedureState::kReadyToAlign);
  engine->controller_lost();
  for (int i = 0; i < 10; ++i)
    engine->poll();
  EXPECT_EQ(engine->status().state, ProcedureState::kReadyToAlign);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
}

TEST_F(EngineTest, AxisAlarmDuringAlignmentLatchesUntilReset) {
  start();
  walk_to(ProcedureState::kAligning);
  ASSERT_TRUE(wait_for([&] { return move_calls() == 1; }));  // the move is running
  card->inject_alarm(config.base.left.card_axis);
  ASSERT_TRUE(wait_for_state(ProcedureState::kFault));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kAxisAlarm);
  EXPECT_TRUE(saw_event(EventKind::kFaultLatched, ErrorCode::kAxisAlarm));
  expect_refused(send(protocol::AlignBase{}), ErrorCode::kFaultLatched);
  ASSERT_TRUE(wait_for([&] { return saw_event(EventKind::kMotionStopped); }));
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToAlign);
  // The card is recovered by the control loop after the Reset: wait for it to report back.
  ASSERT_TRUE(wait_for([&] { return engine->status().card == protocol::DriverState::kActive; }));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
}

TEST_F(EngineTest, MotionDeadlineLatchesTimeout) {
  config.control.motion_timeout_margin_s = 0.01;
  config.base.max_wheel_speed_rad_s = 50;  // a short planned move: the deadline comes quickly
  config.base.max_wheel_accel_rad_s2 = 500;
  start();
  walk_to(ProcedureState::kAligning);
  // Keep the controller alive so that only the deadline can fire.
  ASSERT_TRUE(wait_for([&] {
    engine->controller_heartbeat();
    return engine->status().state == ProcedureState::kFault;
  }));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kMotionTimeout);
}

TEST_F(EngineTest, ArmFaultAndRefusalDuringEngage) {
  start();
  walk_to(ProcedureState::kReadyToEngage);
  arm->fail_next_call(make_error(ErrorCode::kArmDisconnected, "", "mock arm: disconnected"));
  expect_refused(send(protocol::Engage{}), ErrorCode::kArmDisconnected, "arm");
  EXPECT_EQ(engine->status().state, ProcedureState::kReadyToEngage);
  EXPECT_EQ(arm->calls().back(), "hand_off");  // the arm refused the task
  EXPECT_TRUE(arm->tasks().empty());
  expect_ack(send(protocol::Engage{}), ProcedureState::kEngaging);
  arm->set_phase(drivers::ArmPhase::kFault, ErrorCode::kArmRejected);
  ASSERT_TRUE(wait_for_state(ProcedureState::kFault));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kArmRejected);
  expect_ack(send(protocol::Reset{}), ProcedureState::kReadyToEngage);
  EXPECT_GE(arm->count("clear_fault"), 1U);
}

TEST_F(EngineTest, ArmDisconnectDuringEngageLatches) {
  start();
  walk_to(ProcedureState::kEngaging);
  arm->set_phase(drivers::ArmPhase::kDisconnected, ErrorCode::kArmDisconnected);
  ASSERT_TRUE(wait_for_state(ProcedureState::kFault));
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kArmDisconnected);
}

TEST_F(EngineTest, RemeasuredPlaneAfterAlignment) {
  start();
  walk_to(ProcedureState::kReadyToEngage);
  expect_ack(send(plane_at_yaw(0.002)), ProcedureState::kReadyToEngage);  // within tolerance
  expect_ack(send(plane_at_yaw(0.2)), ProcedureState::kReadyToAlign);     // not any more
  EXPECT_FALSE(engine->status().has_contact);
  expect_ack(send(good_width()), ProcedureState::kReadyToAlign);  // width keeps later steps
}

TEST_F(EngineTest, StartupErrorNamesTheDriver) {
  configure_card = [](drivers::MockMotionCard& c) { c.set_open_fails(true); };
  try {
    start();
    FAIL() << "start() should throw";
  } catch (const daemon::StartupError& e) {
    EXPECT_NE(std::string(e.what()).find("motion card"), std::string::npos) << e.what();
  }
}

TEST_F(EngineTest, WelcomeAndHealth) {
  config.control.rate_hz = 250;
  start();
  const auto w = engine->welcome_template();
  EXPECT_EQ(w.loop_rate_hz, 250.0F);
  EXPECT_EQ(w.max_door_width_m, static_cast<float>(config.limits.max_door_width_m));
  EXPECT_GT(w.daemon_version.length, 0);
  EXPECT_EQ(w.driver_kind, protocol::DriverKind::kMock);  // config.drivers.kind
  EXPECT_TRUE(wait_for([&] { return engine->control_loop_healthy(); }));
  // Ping, GetStatus and Subscribe are the session hub's: the engine refuses them.
  expect_refused(send(protocol::Ping{42}), ErrorCode::kWrongState);
  // One clock for everything on the wire: time since the engine (daemon) started.
  // Telemetry is stamped when the loop sampled the wheels (its last cycle), so it may be older
  // than a clock read just before it, never newer than one read after it (CI's TSan stage caught
  // the old `>= t0`: the snapshot's cycle came 1-2 ms before t0).
  const std::uint64_t t0 = engine->daemon_time_ns();
  EXPECT_LT(t0, 3'600ULL * 1'000'000'000ULL);
  const std::uint64_t sampled = engine->telemetry().daemon_time_ns;
  EXPECT_LE(sampled, engine->daemon_time_ns());
  EXPECT_GT(sampled, 0U);
  engine->shutdown();
  EXPECT_FALSE(engine->control_loop_healthy());
}

}  // namespace
}  // namespace ajar::testing
