// A motion card that takes its stops and does not apply them (docs/control-loop.md, "What the
// wheels do"): a smooth stop the wheels do not follow is caught by their speed (not seconds later
// at the stop's deadline) and becomes an emergency stop; wheels that still turn after an
// emergency stop the card took get their servos switched off (MotionCard::disable_axes) every
// cycle until they rest; the card's recovery never switches the servos back on while they turn,
// and the engine refuses a Reset meanwhile. Cycle by cycle on a fake clock over the deterministic
// mock card, whose fault menu drops (accepts, does not apply) the calls.
#include <gtest/gtest.h>

#include <filesystem>
#include <limits>

#include "ajar/daemon/control_loop.hpp"
#include "ajar/daemon/engine.hpp"
#include "ajar/drivers/mock_arm.hpp"
#include "det_loop_fixture.hpp"
#include "fake_door.hpp"

namespace ajar::daemon {
namespace {

using ajar::testing::CardCall;
using ajar::testing::count_calls;
using ajar::testing::kMs;
constexpr int kForever = std::numeric_limits<int>::max();

class UnstoppedWheels : public ajar::testing::DetLoopTest {
 protected:
  void configure(ControlLoopSettings& s) override {
    s.base.max_wheel_speed_rad_s = 10;
    s.drive.max_linear_speed_m_s = 0.3;
    s.drive.max_linear_accel_m_s2 = 0.5;
    s.drive.max_angular_speed_rad_s = 0.6;
    s.drive.max_angular_accel_rad_s2 = 1.0;
    s.drive.command_timeout_s = 0.5;
    s.control.motion_timeout_margin_s = 2.0;  // the default: a stop's deadline is seconds away
  }
  // A jog at 0.3 m/s, the key held.
  void jog_at_speed() {
    ASSERT_TRUE(loop->post_drive(DriveCommand{1, true, {0.3, 0.0}, now()}));
    for (int i = 0; i < 8; ++i) {
      run(50);
      ASSERT_TRUE(loop->post_drive(DriveCommand{1, false, {0.3, 0.0}, now()}));
    }
    ASSERT_TRUE(card.any_moving());
  }
  // The first logged call of `kind` from `from` on: its time on the card's clock (-1: none).
  std::int64_t first_call_ns(CardCall kind, std::size_t from) const {
    for (const auto& c : card.log_from(from))
      if (c.kind == kind) return c.at_ns;
    return -1;
  }
};

// Before: the wheels ran on at full speed until the stop's deadline (1.5 x the stop time +
// control.motion_timeout_margin_s: 2.9 s here) before the emergency stop.
TEST_F(UnstoppedWheels, ASmoothStopTheWheelsDoNotFollowBecomesAnEmergencyStopAtOnce) {
  jog_at_speed();
  card.drop_next_calls(CardCall::kSmoothStop, kForever);
  const std::size_t from = card.log_size();
  const std::int64_t asked = now();
  loop->request_stop();
  run(600);  // 1.2 s
  const std::int64_t estop = first_call_ns(CardCall::kEmergencyStop, from);
  ASSERT_GE(estop, 0) << "a smooth stop the card did not apply went on unchecked";
  // Once the deceleration the wheels should follow (1.5 s from this speed to rest) takes them out
  // of the tolerance (10 % of the wheel speed limit, 10 rad/s here, + 0.1 s of the ramp: 0.6 s),
  // plus velocity_mismatch_s (0.2 s); the stop's deadline was 1.5 x 1.5 s + 2 s.
  EXPECT_LE(estop - asked, 1000 * kMs) << (estop - asked) / kMs << " ms";
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kVelocityMismatch);
  EXPECT_FALSE(card.any_moving());
}

// A smooth stop the card applies is not mistaken for one it does not.
TEST_F(UnstoppedWheels, ASmoothStopTheWheelsFollowStaysSmooth) {
  jog_at_speed();
  const std::size_t from = card.log_size();
  loop->request_stop();
  run(500);
  EXPECT_EQ(count_calls(card, CardCall::kEmergencyStop, from), 0);
  EXPECT_EQ(count_calls(card, CardCall::kDisableAxes, from), 0);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);
  EXPECT_FALSE(card.any_moving());
}

// Before: the loop re-sent the emergency stop every cycle and had nothing stronger; the base ran
// on.
TEST_F(UnstoppedWheels, WheelsThatIgnoreAnEmergencyStopGetTheirServosSwitchedOff) {
  jog_at_speed();
  card.drop_next_calls(CardCall::kSmoothStop, kForever);
  card.drop_next_calls(CardCall::kEmergencyStop, kForever);
  const std::size_t from = card.log_size();
  const std::int64_t asked = now();
  loop->request_emergency_stop();
  bool unstopped_seen = false;
  for (int i = 0; i < 300; ++i) {
    run(1);
    unstopped_seen = unstopped_seen || loop->snapshot().unstopped;
  }
  const std::int64_t off = first_call_ns(CardCall::kDisableAxes, from);
  ASSERT_GE(off, 0) << "the wheels ignored the emergency stop and nothing stronger was tried";
  EXPECT_LE(off - asked, 250 * kMs);
  EXPECT_TRUE(unstopped_seen);
  EXPECT_FALSE(card.any_moving()) << "servo off stops the mock's wheels";
  EXPECT_FALSE(loop->snapshot().unstopped) << "at rest again";
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kEmergencyStopped);  // the first fault stays
}

// Nothing the card is told stops the wheels: the servo-off is repeated every cycle, the fault
// stays latched, and a recovery never switches the servos back on while they turn.
TEST_F(UnstoppedWheels, ARecoveryNeverSwitchesTheServosOnWhileTheWheelsTurn) {
  jog_at_speed();
  card.drop_next_calls(CardCall::kSmoothStop, kForever);
  card.drop_next_calls(CardCall::kEmergencyStop, kForever);
  card.drop_next_calls(CardCall::kDisableAxes, kForever);
  loop->request_emergency_stop();
  run(200);
  ASSERT_TRUE(loop->snapshot().unstopped);
  const std::size_t from = card.log_size();
  ASSERT_TRUE(loop->request_recover(1));
  run(100);
  EXPECT_EQ(count_calls(card, CardCall::kEnableAxes, from), 0)
      << "the recovery switched the servos on under wheels that still turn";
  EXPECT_GE(count_calls(card, CardCall::kDisableAxes, from), 90) << "every cycle";
  EXPECT_NE(loop->snapshot().fault, ErrorCode::kOk);
  bool recovered = false;
  for (const auto& r : reports())
    if (r.kind == LoopReportKind::kRecovered && r.sequence == 1) {
      recovered = true;
      EXPECT_NE(r.code, ErrorCode::kOk);
    }
  EXPECT_TRUE(recovered) << "the recover request is answered (with the fault)";
  // The card obeys again: the wheels rest, and a recovery brings the servos back.
  card.drop_next_calls(CardCall::kDisableAxes, 0);
  card.drop_next_calls(CardCall::kEmergencyStop, 0);
  card.drop_next_calls(CardCall::kSmoothStop, 0);
  run(10);
  EXPECT_FALSE(card.any_moving());
  EXPECT_FALSE(loop->snapshot().unstopped);
  ASSERT_TRUE(loop->request_recover(2));
  run(50);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);
  EXPECT_GE(count_calls(card, CardCall::kEnableAxes, from), 1);
}

// The engine: Reset is refused (MOTION_IN_PROGRESS, the fault stays) while the wheels turn after
// an emergency stop the card took; accepted once they rest.
TEST(UnstoppedWheelsEngine, ResetIsRefusedWhileTheWheelsStillTurn) {
  ajar::testing::TempDir dir;
  ajar::testing::FakeClock clock;
  auto config = ajar::testing::test_config(dir.path());
  config.recorder.enabled = false;
  drivers::DriverSet set;
  set.card = ajar::testing::make_det_card(clock);
  auto& card = static_cast<drivers::MockMotionCard&>(*set.card);
  set.arm =
      std::make_unique<drivers::MockManipulator>(drivers::MockArmFault::kStuck, 40, clock.clock());
  EngineOptions options;
  options.now_ns = clock.clock();
  options.manual_loop = true;
  auto engine = make_engine(config, std::move(set), std::move(options));
  std::vector<protocol::Event> events;
  engine->set_event_sink([&](const protocol::Event& e) { events.push_back(e); });
  engine->start();
  const auto cycles = [&](int n) {
    for (int i = 0; i < n; ++i) {
      clock.advance_ns(2'000'000);
      engine->controller_heartbeat();
      engine->run_loop_cycle();
      engine->poll();
    }
  };
  cycles(3);
  for (int i = 0; i < 6; ++i) {
    ASSERT_TRUE(
        std::holds_alternative<protocol::Ack>(engine->handle_command(protocol::Drive{0.2, 0.0})));
    cycles(50);
  }
  ASSERT_TRUE(card.any_moving());
  card.drop_next_calls(CardCall::kSmoothStop, kForever);
  card.drop_next_calls(CardCall::kEmergencyStop, kForever);
  card.drop_next_calls(CardCall::kDisableAxes, kForever);
  ASSERT_TRUE(
      std::holds_alternative<protocol::Ack>(engine->handle_command(protocol::EmergencyStop{})));
  cycles(200);
  events.clear();
  const auto refused = engine->handle_command(protocol::Reset{false});
  const auto* error = std::get_if<protocol::ErrorReply>(&refused);
  ASSERT_NE(error, nullptr) << "a Reset was accepted while the wheels still turn";
  EXPECT_EQ(error->code, ErrorCode::kMotionInProgress);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kEmergencyStopped);
  for (const auto& e : events)
    EXPECT_NE(e.kind, protocol::EventKind::kFaultCleared);
  bool told = false;
  for (const auto& w : engine->take_warnings())
    told = told || w.find("servos are being switched off") != std::string::npos;
  EXPECT_TRUE(told) << "the journal is told";
  // The card obeys the servo-off again: the wheels rest; Reset recovers.
  card.drop_next_calls(CardCall::kDisableAxes, 0);
  cycles(20);
  ASSERT_FALSE(card.any_moving());
  EXPECT_TRUE(
      std::holds_alternative<protocol::Ack>(engine->handle_command(protocol::Reset{false})));
  cycles(50);
  EXPECT_EQ(engine->status().latched_fault, ErrorCode::kOk);
  engine->shutdown();
}

}  // namespace
}  // namespace ajar::daemon
