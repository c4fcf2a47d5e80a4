// The loop's jog (Drive): the speed limiter, the command timeout (while the controller keeps
// pinging), stops and the deadman ending a jog, odometry while driving, and a move refused in a
// cycle whose status read failed. Cycle by cycle on a fake clock over the deterministic card.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "ajar/daemon/control_loop.hpp"
#include "det_loop_fixture.hpp"

namespace ajar::daemon {
namespace {

using ajar::testing::CardCall;
using ajar::testing::count_calls;
using ajar::testing::kMs;

class LoopDrive : public ajar::testing::DetLoopTest {
 protected:
  void configure(ControlLoopSettings& s) override {
    s.base.max_wheel_speed_rad_s = 10;  // the body limits below are what binds
    s.drive.max_linear_speed_m_s = 0.3;
    s.drive.max_linear_accel_m_s2 = 0.5;
    s.drive.max_angular_speed_rad_s = 0.6;
    s.drive.max_angular_accel_rad_s2 = 1.0;
    s.drive.command_timeout_s = 0.5;
  }
  DriveCommand drive(std::uint32_t id, bool start, double v, double w) const {
    return DriveCommand{id, start, {v, w}, now()};
  }
  std::vector<drivers::CardCallRecord> jogs() const {
    std::vector<drivers::CardCallRecord> out;
    for (const auto& c : card.log_from(log_start))
      if (c.kind == CardCall::kJog) out.push_back(c);
    return out;
  }
  // counts/ms at the card for a wheel speed (rad/s), polarity applied.
  double card_velocity(double wheel_rad_s, int polarity) const {
    const auto& b = settings.base;
    return wheel_rad_s * b.gear_ratio * b.encoder_counts_per_rev / (2 * std::numbers::pi) / 1e3 *
           polarity;
  }
};

TEST_F(LoopDrive, LimiterRampsAtTheAccelerationAndClampsTheSpeed) {
  ASSERT_TRUE(loop->post_drive(drive(1, true, 5.0, 0.0)));  // far above the speed limit
  double previous = 0;
  for (int i = 0; i < 400; ++i) {  // 0.8 s: 0.6 s to reach the speed limit
    if (i % 50 == 0) {
      ASSERT_TRUE(loop->post_drive(drive(1, false, 5.0, 0.0)));  // held key
    }
    run(1);
    const double v = loop->snapshot().commanded.linear_m_s;
    EXPECT_LE(v - previous, 0.5 * 0.002 + 1e-12) << "cycle " << i;  // acceleration limit
    EXPECT_LE(v, 0.3 + 1e-12) << "cycle " << i;                     // speed limit
    previous = v;
  }
  EXPECT_DOUBLE_EQ(previous, 0.3);
  // The card got the wheel velocities of the limited body velocity (both wheels forward).
  const auto last = jogs().back();
  const double wheel = 0.3 / settings.base.wheel_radius_m;
  EXPECT_NEAR(last.velocity_counts_per_ms(left_axis),
              card_velocity(wheel, settings.base.left.polarity), 1e-9);
  EXPECT_NEAR(last.velocity_counts_per_ms(right_axis),
              card_velocity(wheel, settings.base.right.polarity), 1e-9);
  EXPECT_TRUE(reports().empty());  // still jogging
  EXPECT_TRUE(loop->snapshot().jogging);
}

// The wheel-speed cap binds before the body limits: commanded_* (the snapshot's `commanded`) is
// what the wheels are told, not the body command above the cap (issue 24: a 5 m/s Drive with a
// 1 rad/s wheel cap showed 0.300 m/s while the wheels were told R_W * 1 rad/s).
class LoopDriveWheelCap : public LoopDrive {
 protected:
  void configure(ControlLoopSettings& s) override {
    LoopDrive::configure(s);
    s.base.max_wheel_speed_rad_s = 1.0;
  }
};

TEST_F(LoopDriveWheelCap, CommandedIsWhatTheWheelsAreToldAfterTheWheelSpeedCap) {
  const double r_w = settings.base.wheel_radius_m;
  ASSERT_LT(r_w * 1.0, 0.3) << "the wheel cap must bind before the body speed limit";
  ASSERT_TRUE(loop->post_drive(drive(1, true, 5.0, 0.0)));
  for (int i = 0; i < 400; ++i) {
    if (i % 50 == 0) {
      ASSERT_TRUE(loop->post_drive(drive(1, false, 5.0, 0.0)));
    }
    run(1);
    EXPECT_LE(loop->snapshot().commanded.linear_m_s, r_w * 1.0 + 1e-12) << "cycle " << i;
  }
  const auto snap = loop->snapshot();
  EXPECT_NEAR(snap.commanded.linear_m_s, r_w * 1.0, 1e-12);
  EXPECT_EQ(snap.commanded.angular_rad_s, 0.0);
  const auto last = jogs().back();  // and that is what the card was told
  EXPECT_NEAR(last.velocity_counts_per_ms(left_axis),
              card_velocity(snap.commanded.linear_m_s / r_w, settings.base.left.polarity), 1e-9);
  // Turning on the spot at the angular limit: the wheels at the cap, the yaw rate with them.
  for (int i = 0; i < 400; ++i) {
    if (i % 50 == 0) {
      ASSERT_TRUE(loop->post_drive(drive(1, false, 0.0, 0.6)));
    }
    run(1);
  }
  const double r_b = settings.base.turning_radius_m;
  const double yaw_rate = std::min(0.6, 1.0 * r_w / r_b);
  EXPECT_NEAR(loop->snapshot().commanded.angular_rad_s, yaw_rate, 1e-9);
}

TEST_F(LoopDrive, CommandTimeoutStopsAJogWhileTheControllerKeepsPinging) {
  ASSERT_TRUE(loop->post_drive(drive(7, true, 0.2, 0.3)));
  run(250);  // 0.5 s: just within the timeout, at speed
  EXPECT_NEAR(loop->snapshot().commanded.linear_m_s, 0.2, 1e-9);
  EXPECT_NEAR(loop->snapshot().commanded.angular_rad_s, 0.3, 1e-9);
  EXPECT_TRUE(reports().empty());
  run(400);  // past 0.5 s without a new Drive (heartbeats go on): decelerate to rest
  const auto snap = loop->snapshot();
  EXPECT_EQ(snap.commanded.linear_m_s, 0.0);
  EXPECT_EQ(snap.commanded.angular_rad_s, 0.0);
  run(10);
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMotionFinished);
  EXPECT_EQ(rs[0].motion_id, 7U);
  EXPECT_TRUE(rs[0].command_timeout);
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kOk);  // a timeout is not a fault
  EXPECT_FALSE(loop->snapshot().motion_active);
  EXPECT_EQ(jogs().back().velocity_counts_per_ms(left_axis), 0.0);
  EXPECT_FALSE(card.any_moving());
}

TEST_F(LoopDrive, ZeroVelocityIsASmoothStopThatEndsTheJog) {
  ASSERT_TRUE(loop->post_drive(drive(3, true, 0.3, 0.0)));
  for (int i = 0; i < 4; ++i) {  // held for 0.8 s
    ASSERT_TRUE(loop->post_drive(drive(3, false, 0.3, 0.0)));
    run(100);
  }
  ASSERT_TRUE(loop->post_drive(drive(3, false, 0.0, 0.0)));
  run(1);
  const double first = loop->snapshot().commanded.linear_m_s;
  EXPECT_NEAR(first, 0.3 - 0.5 * 0.002, 1e-12);  // decelerating, not a jump to zero
  run(400);
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMotionFinished);
  EXPECT_FALSE(rs[0].command_timeout);
}

TEST_F(LoopDrive, StopEndsAJogInTheNextCycleAndNothingJogsAfterIt) {
  ASSERT_TRUE(loop->post_drive(drive(2, true, 0.3, 0.0)));
  run(50);
  loop->request_stop();
  ASSERT_TRUE(loop->post_drive(drive(2, false, 0.3, 0.0)));  // an update behind the stop
  const std::size_t at_stop = card.log_size();
  run(1);
  EXPECT_EQ(count_calls(card, CardCall::kSmoothStop, at_stop), 1)
      << "no smooth stop in the next cycle";
  run(19);
  EXPECT_EQ(count_calls(card, CardCall::kJog, at_stop), 0) << "a jog after the stop";
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMotionStopped);
  EXPECT_EQ(loop->snapshot().commanded.linear_m_s, 0.0);
}

TEST_F(LoopDrive, AJogStartPostedBeforeAStopNeverReachesTheCard) {
  ASSERT_TRUE(loop->post_drive(drive(4, true, 0.3, 0.0)));
  loop->request_stop();
  run(5);
  EXPECT_TRUE(jogs().empty());
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMoveCancelled);
  EXPECT_EQ(rs[0].motion_id, 4U);
}

TEST_F(LoopDrive, DeadmanStopsAJogAndLatches) {
  settings.safety.deadman_timeout_s = 0.1;
  make_loop();
  loop->heartbeat(now());
  ASSERT_TRUE(loop->post_drive(drive(5, true, 0.3, 0.0)));
  for (int i = 0; i < 100; ++i) {  // Drive updates keep coming, but the controller is silent
    if (i % 20 == 0) {
      ASSERT_TRUE(loop->post_drive(drive(5, false, 0.3, 0.0)));
    }
    run(1, false);
  }
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kDeadman);
  const auto rs = reports();
  ASSERT_GE(rs.size(), 2U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kFault);
  EXPECT_EQ(rs[0].code, ErrorCode::kDeadman);
  EXPECT_EQ(rs[1].kind, LoopReportKind::kMotionStopped);
}

TEST_F(LoopDrive, AJogIsRefusedWhileAMoveRunsAndAMoveWhileAJogRuns) {
  ASSERT_TRUE(loop->post_move({1, 50000, 50000}));
  ASSERT_TRUE(loop->post_drive(drive(2, true, 0.3, 0.0)));
  run(1);
  auto rs = reports();
  ASSERT_EQ(rs.size(), 1U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMoveRefused);
  EXPECT_EQ(rs[0].motion_id, 2U);
  EXPECT_EQ(rs[0].code, ErrorCode::kMotionInProgress);
  EXPECT_TRUE(jogs().empty());
}

TEST_F(LoopDrive, OdometryFollowsTheWheelsWhileDriving) {
  ASSERT_TRUE(loop->post_drive(drive(1, true, 0.2, 0.0)));
  for (int i = 0; i < 500; ++i) {
    if (i % 50 == 0) {
      ASSERT_TRUE(loop->post_drive(drive(1, false, 0.2, 0.0)));
    }
    run(1);
  }
  const auto snap = loop->snapshot();
  // Straight ahead: x is the distance the wheels rolled, y and yaw stay 0.
  const double rolled = settings.base.wheel_radius_m * snap.left_wheel_rad;
  EXPECT_GT(snap.pose.x_m, 0.15);
  EXPECT_NEAR(snap.pose.x_m, rolled, 1e-6);
  EXPECT_NEAR(snap.pose.y_m, 0.0, 1e-9);
  EXPECT_NEAR(snap.base_yaw_rad, 0.0, 1e-9);
}

// v / w = 0.5 m throughout (both components reach their limits after the same 0.2 s ramp), so the
// true path is a circle of radius 0.5 m whatever the speed profile: x = r sin(yaw),
// y = r (1 - cos(yaw)). The odometry, from the card's encoders, must stay on it.
TEST_F(LoopDrive, OdometryOnAnArcMatchesTheKinematicCircle) {
  ASSERT_TRUE(loop->post_drive(drive(1, true, 0.1, 0.2)));
  for (int i = 0; i < 2500; ++i) {  // 5 s: yaw about 0.96 rad
    if (i % 50 == 0) {
      ASSERT_TRUE(loop->post_drive(drive(1, false, 0.1, 0.2)));
    }
    run(1);
  }
  const auto snap = loop->snapshot();
  const double r = 0.1 / 0.2, yaw = snap.base_yaw_rad;
  ASSERT_GT(yaw, 0.8);
  EXPECT_NEAR(snap.pose.x_m, r * std::sin(yaw), 1e-4);
  EXPECT_NEAR(snap.pose.y_m, r * (1 - std::cos(yaw)), 1e-4);
}

TEST_F(LoopDrive, AMoveIsRefusedInACycleWhoseStatusReadFailed) {
  run(1);
  card.fail_next_calls(2);  // both axis_status reads of the next cycle fail
  ASSERT_TRUE(loop->post_move({9, 1000, 1000}));
  run(1);
  EXPECT_EQ(calls(CardCall::kMoveRelative), 0);
  EXPECT_EQ(card.calls(CardCall::kMoveRelative), 0U);  // not even tried
  const auto rs = reports();
  ASSERT_EQ(rs.size(), 2U);
  EXPECT_EQ(rs[0].kind, LoopReportKind::kMoveRefused);
  EXPECT_EQ(rs[0].code, ErrorCode::kCardCommunication);
  // ... and the idle supervision latches the silence in the same cycle (the card's lifecycle
  // wrapper has latched it too: no move runs until a recovery).
  EXPECT_EQ(rs[1].kind, LoopReportKind::kFault);
  EXPECT_EQ(rs[1].code, ErrorCode::kCardCommunication);
}

}  // namespace
}  // namespace ajar::daemon
