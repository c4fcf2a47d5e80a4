// The loop's limits where the card is told, and every motion's deadline against a card that
// misbehaves (issue 22, items 1 and 7): the trapezoid a move gets comes from its profile (an
// Approach's body limits), a jog's ramp from the drive limits; a jog whose card misses the zero
// update, a card that reports stale status, answers an error after taking a command or stops
// answering for a while end in an emergency stop and a latched fault. Cycle by cycle on a fake
// clock over the deterministic card.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "ajar/core/driving.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "det_loop_fixture.hpp"

namespace ajar::daemon {
namespace {

using ajar::testing::CardCall;
using ajar::testing::count_calls;

class LoopLimits : public ajar::testing::DetLoopTest {
 protected:
  void configure(ControlLoopSettings& s) override {
    // The reported configuration: a slow body, well below the wheels' own limits (0.1 m/s).
    s.drive.max_linear_speed_m_s = 0.02;
    s.drive.max_linear_accel_m_s2 = 0.05;
    s.drive.max_angular_accel_rad_s2 = 0.1;
  }
  // counts/ms (and counts/ms^2) at the card per m/s (m/s^2) of the body going straight.
  double counts_per_ms_per_m_s() const {
    const auto& b = settings.base;
    return b.gear_ratio * b.encoder_counts_per_rev / (2 * std::numbers::pi) / b.wheel_radius_m /
           1e3;
  }
  std::vector<drivers::CardCallRecord> calls_of(CardCall kind) const {
    std::vector<drivers::CardCallRecord> out;
    for (const auto& c : card.log_from(log_start))
      if (c.kind == kind) out.push_back(c);
    return out;
  }
};

// Item 1: an Approach (kStraight) cruised at the wheels' speed, five times its limit. The card
// must be told the body's limits, and the wheels must keep them.
TEST_F(LoopLimits, AStraightMoveIsToldAndKeepsTheBodysSpeedAndAcceleration) {
  const auto straight = core::straight_command(0.03, settings.base);
  ASSERT_TRUE(
      loop->post_move({1, straight.left_counts, straight.right_counts, MoveProfile::kStraight}));
  double fastest = 0;
  for (int i = 0; i < 2000 && loop->snapshot().motion_active == (i > 0); ++i) {
    run(1);
    fastest = std::max(
        {fastest, std::abs(card.velocity(left_axis)), std::abs(card.velocity(right_axis))});
  }
  const auto moves = calls_of(CardCall::kMoveRelative);
  ASSERT_EQ(moves.size(), 1U);
  const double speed_limit = 0.02 * counts_per_ms_per_m_s();
  const double accel_limit = 0.05 * counts_per_ms_per_m_s() / 1e3;
  EXPECT_LE(moves[0].profile.velocity_counts_per_ms, speed_limit * (1 + 1e-12))
      << "the card was told a straight move faster than drive.max_linear_speed_m_s";
  EXPECT_LE(moves[0].profile.acceleration_counts_per_ms2, accel_limit * (1 + 1e-12));
  EXPECT_LE(moves[0].profile.deceleration_counts_per_ms2, accel_limit * (1 + 1e-12));
  EXPECT_LE(fastest, speed_limit * (1 + 1e-9)) << "the wheels ran faster than the limit";
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMotionFinished) << "its deadline is from its profile";
}

// A move whose counts are not a turn in place keeps the body's limits whatever kind it says.
TEST_F(LoopLimits, AMoveThatIsNotATurnInPlaceKeepsTheBodyLimitsWhateverItsKind) {
  const auto straight = core::straight_command(0.01, settings.base);
  ASSERT_TRUE(
      loop->post_move({1, straight.left_counts, straight.right_counts, MoveProfile::kTurn}));
  run(1);
  const auto moves = calls_of(CardCall::kMoveRelative);
  ASSERT_EQ(moves.size(), 1U);
  EXPECT_LE(moves[0].profile.velocity_counts_per_ms, 0.02 * counts_per_ms_per_m_s() * (1 + 1e-12));
  // A turn in place runs on the wheel limits.
  EXPECT_EQ(move_profile({2, 100, 100, MoveProfile::kTurn}, settings.base, settings.drive)
                .velocity_counts_per_ms,
            wheel_profile(settings.base).velocity_counts_per_ms);
}

// A jog's ramp at the card: never above what the drive limits allow a wheel.
TEST_F(LoopLimits, TheJogRampAtTheCardStaysWithinTheDriveLimits) {
  ASSERT_TRUE(loop->post_drive({1, true, {0.02, 0.0}, now()}));
  run(20);
  const auto jogs = calls_of(CardCall::kJog);
  ASSERT_FALSE(jogs.empty());
  const auto& b = settings.base;
  const double wheel_rad_s2 = (0.05 + 0.1 * b.turning_radius_m) / b.wheel_radius_m;
  const double limit =
      wheel_rad_s2 * b.gear_ratio * b.encoder_counts_per_rev / (2 * std::numbers::pi) / 1e6;
  for (const auto& j : jogs) {
    EXPECT_LE(j.jog_profile.acceleration_counts_per_ms2, limit * (1 + 1e-12));
    EXPECT_LE(j.jog_profile.deceleration_counts_per_ms2, limit * (1 + 1e-12));
  }
}

class LoopDeadlines : public ajar::testing::DetLoopTest {
 protected:
  void configure(ControlLoopSettings& s) override {
    s.control.motion_timeout_margin_s = 0.2;
    s.drive.command_timeout_s = 0.5;
  }
  // Holds a 0.1 m/s jog (the wheels' top speed) for `cycles`, re-sending the Drive.
  void jog_at_speed(int cycles) {
    ASSERT_TRUE(loop->post_drive({1, true, {0.1, 0.0}, now()}));
    for (int i = 0; i < cycles; ++i) {
      if (i % 50 == 49) {
        ASSERT_TRUE(loop->post_drive({1, false, {0.1, 0.0}, now()}));
      }
      run(1);
    }
    ASSERT_TRUE(card.jogging(left_axis));
    ASSERT_EQ(loop->snapshot().fault, ErrorCode::kOk);
  }
  static bool has(const std::vector<LoopReport>& rs, LoopReportKind kind) {
    for (const auto& r : rs)
      if (r.kind == kind) return true;
    return false;
  }
  // The jog's stop, as docs/control-loop.md promises it: the limiter's ramp to zero, then the
  // card's ramp to rest (1.5x), the margin; or the velocity check's window. In cycles.
  int jog_rest_bound_cycles() const {
    const auto& d = settings.drive;
    const double ramp_s = 0.1 / d.max_linear_accel_m_s2;
    const double wheel_s =
        settings.base.max_wheel_speed_rad_s / settings.base.max_wheel_accel_rad_s2;
    const double s = ramp_s + 1.5 * wheel_s + settings.control.motion_timeout_margin_s;
    return static_cast<int>(s / 0.002) + 2;
  }
};

// Item 7: the card accepts GT_SetVel but misses the updates: the base kept 0.1 m/s for 8 s while
// the daemon commanded 0. Now the jog's deadline (and the velocity check) end it: emergency stop,
// latched fault, wheels at rest.
TEST_F(LoopDeadlines, AJogWhoseCardMissesTheZeroUpdateIsEmergencyStoppedAndLatches) {
  jog_at_speed(250);
  card.drop_next_calls(CardCall::kJog, 1'000'000);  // every later GT_SetVel accepted, not applied
  const std::size_t at_release = card.log_size();
  ASSERT_TRUE(loop->post_drive({1, false, {0.0, 0.0}, now()}));  // the key released
  const int cycles = run_until_fault(4000);
  EXPECT_LE(cycles, jog_rest_bound_cycles()) << "the jog overran its deadline to come to rest";
  const ErrorCode fault = loop->snapshot().fault;
  EXPECT_TRUE(fault == ErrorCode::kVelocityMismatch || fault == ErrorCode::kMotionTimeout)
      << to_string(fault);
  EXPECT_EQ(count_calls(card, CardCall::kEmergencyStop, at_release), 1);
  run(2);
  EXPECT_FALSE(card.any_moving());
  const auto rs = reports();
  EXPECT_TRUE(has(rs, LoopReportKind::kFault));
  EXPECT_TRUE(has(rs, LoopReportKind::kMotionStopped));
  EXPECT_FALSE(loop->snapshot().motion_active);
}

// The same by the command timeout, and a card that misses only the last (zero) update: the
// wheels creep at one limiter step; the jog's deadline to come to rest catches it.
TEST_F(LoopDeadlines, AJogWhoseCardMissesOnlyTheLastUpdateTimesOut) {
  jog_at_speed(100);  // no further Drive: the command timeout ramps it down
  const double step = settings.drive.max_linear_accel_m_s2 * 0.002;
  int n = 0;
  while (n++ < 2000 && !(loop->snapshot().commanded.linear_m_s <= step + 1e-12))
    run(1);
  ASSERT_GT(loop->snapshot().commanded.linear_m_s, 0.0);
  card.drop_next_calls(CardCall::kJog, 1);  // the zero
  const std::size_t at_drop = card.log_size();
  // From the moment it was told zero: the card's ramp from the wheels' top speed (1.5x) and the
  // margin.
  const int cycles = run_until_fault(4000);
  const auto& b = settings.base;
  EXPECT_LE(cycles, static_cast<int>((b.max_wheel_speed_rad_s / b.max_wheel_accel_rad_s2 * 1.5 +
                                      settings.control.motion_timeout_margin_s) /
                                     0.002) +
                        3);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kMotionTimeout);
  EXPECT_EQ(count_calls(card, CardCall::kEmergencyStop, at_drop), 1);
  run(2);
  EXPECT_FALSE(card.any_moving());
}

// Stale status while jogging: the encoders seem to stand still while the card was told to move.
TEST_F(LoopDeadlines, StaleStatusDuringAJogIsCaught) {
  jog_at_speed(100);
  card.set_stale_status_reads(1'000'000);
  const int cycles = run_until_fault(1000);
  EXPECT_LE(cycles, static_cast<int>(settings.velocity_mismatch_s / 0.002) + 3);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kVelocityMismatch);
  EXPECT_GE(card.calls(CardCall::kEmergencyStop), 1U);
  card.set_stale_status_reads(0);
  run(2);
  EXPECT_FALSE(card.any_moving());
}

// A card that takes a move and then answers an error: the loop reports the move refused, and the
// wheels must not run on unsupervised.
TEST_F(LoopDeadlines, AMoveTheCardTookButAnsweredWithAnErrorIsEmergencyStopped) {
  card.fail_after_next_call(CardCall::kMoveRelative);
  ASSERT_TRUE(loop->post_move({1, 50'000, -50'000}));
  run(1);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kCardCommunication);
  EXPECT_EQ(calls(CardCall::kEmergencyStop), 1);
  EXPECT_FALSE(card.any_moving());
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 2U);
  EXPECT_EQ(rs[1].kind, LoopReportKind::kMoveRefused);
}

// The card stops answering mid-jog (every call, the stops too): nothing can reach it; once it
// answers again the wheels are emergency-stopped at once.
TEST_F(LoopDeadlines, ACardThatStopsAnsweringMidJogIsStoppedWhenItAnswersAgain) {
  jog_at_speed(100);
  card.stop_answering_for_ns(40 * kMs);  // 20 cycles
  run(1);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kCardCommunication);
  run(18);
  ASSERT_FALSE(card.answering());
  EXPECT_TRUE(card.jogging(left_axis)) << "the silent card ran on (nothing could stop it)";
  run(1);
  ASSERT_TRUE(card.answering());
  EXPECT_FALSE(card.any_moving()) << "not stopped in the first cycle the card answered";
  run(2);
  EXPECT_TRUE(has(reports(), LoopReportKind::kMotionStopped));
}

// A move that overruns its deadline is emergency-stopped (not trusted with a smooth stop).
TEST_F(LoopDeadlines, AMoveTheCardDoesNotApplyMissesItsDeadlineAndIsEmergencyStopped) {
  card.drop_next_calls(CardCall::kMoveRelative);
  ASSERT_TRUE(loop->post_move({1, 1000, -1000}));
  const double deadline_s = planned_duration_s(1000, wheel_profile(settings.base)) * 1.5 +
                            settings.control.motion_timeout_margin_s;
  const int cycles = run_until_fault(2000);
  EXPECT_LE(cycles, static_cast<int>(deadline_s / 0.002) + 2);
  EXPECT_GE(cycles, static_cast<int>(deadline_s / 0.002) - 1);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kMotionTimeout);
  EXPECT_EQ(calls(CardCall::kEmergencyStop), 1);
  EXPECT_EQ(calls(CardCall::kSmoothStop), 0);
}

// Wheels that move while no motion runs (a smooth stop the card took, reported at rest, but did
// not apply: here a stale "at rest" that hides a jog) are emergency-stopped and latch.
TEST_F(LoopDeadlines, WheelsMovingWithoutAMotionAreEmergencyStopped) {
  const drivers::AxisVelocity v[] = {{left_axis, 20.0}, {right_axis, -20.0}};
  run(5);
  ASSERT_EQ(card.jog(v, jog_profile(settings.base, settings.drive)), ErrorCode::kOk);
  const int cycles = run_until_fault(1000);
  EXPECT_LE(cycles, static_cast<int>(settings.velocity_mismatch_s / 0.002) + 2);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kVelocityMismatch);
  EXPECT_FALSE(card.any_moving());
}

}  // namespace
}  // namespace ajar::daemon
