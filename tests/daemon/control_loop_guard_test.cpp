// The forward jog's door guard in the loop (issue 23): with a fresh door distance a forward jog
// stops at the standoff from the loop's own odometry (a position bound every cycle, not a check
// at acceptance), along a braking curve the limiter can follow; with a stale distance the forward
// speed is capped; backing off and turning are never limited. Cycle by cycle on a fake clock over
// the deterministic card.
#include <cmath>

#include <gtest/gtest.h>

#include "ajar/daemon/control_loop.hpp"
#include "det_loop_fixture.hpp"

namespace ajar::daemon {
namespace {

class LoopDoorGuard : public ajar::testing::DetLoopTest {
 protected:
  void configure(ControlLoopSettings& s) override {
    s.base.max_wheel_speed_rad_s = 3;  // 0.3 m/s: the drive limits bind
    s.base.max_wheel_accel_rad_s2 = 10;
    s.drive.max_linear_speed_m_s = 0.3;
    s.drive.max_linear_accel_m_s2 = 0.5;
    s.drive.command_timeout_s = 0.5;
  }
  // A door square ahead at `distance_m` from the odometry origin (normal toward the robot).
  static DoorGuard door_ahead(double distance_m, double standoff_m = 0.4) {
    DoorGuard g;
    g.mode = DoorGuard::Mode::kStandoff;
    g.line = {-1.0, 0.0, distance_m};
    g.standoff_m = standoff_m;
    return g;
  }
  double distance(const DoorGuard& g) const {
    const auto p = loop->snapshot().pose;
    return core::door_distance_m(g.line, p.x_m, p.y_m);
  }
  // Holds the key (re-sent every 0.1 s) for n cycles; checks every cycle that the commanded speed
  // ramps within the acceleration limit.
  void hold(double v, double w, int n) {
    for (int i = 0; i < n; ++i) {
      if (i % 50 == 0) {
        ASSERT_TRUE(loop->post_drive({1, started_ ? false : true, {v, w}, now()}));
        started_ = true;
      }
      const double before = loop->snapshot().commanded.linear_m_s;
      run(1);
      const double after = loop->snapshot().commanded.linear_m_s;
      ASSERT_LE(std::abs(after - before), settings.drive.max_linear_accel_m_s2 * 0.002 + 1e-12)
          << "cycle " << i;
    }
  }
  bool started_ = false;
};

TEST_F(LoopDoorGuard, AForwardJogHeldTowardTheDoorStopsAtTheStandoff) {
  const DoorGuard guard = door_ahead(1.0);
  ASSERT_TRUE(loop->post_door_guard(guard));
  hold(0.3, 0.0, 2000);  // 4 s: without the guard the base would drive through the door
  EXPECT_GE(distance(guard), 0.4 - 0.002) << "the base drove past the standoff";
  EXPECT_LE(distance(guard), 0.4 + 0.005) << "the base stopped short of the standoff";
  EXPECT_FALSE(card.any_moving());
  const auto snap = loop->snapshot();
  EXPECT_TRUE(snap.jogging) << "the jog ended while the key is held";
  EXPECT_TRUE(snap.guard_limiting);
  EXPECT_EQ(snap.guard_limit_m_s, 0.0);
  EXPECT_EQ(snap.commanded.linear_m_s, 0.0);
  EXPECT_EQ(snap.fault, ErrorCode::kOk) << "held at rest is not a missed deadline";
  // Backing off is not limited.
  const double x = snap.pose.x_m;
  hold(-0.1, 0.0, 200);
  EXPECT_LT(loop->snapshot().pose.x_m, x - 0.02);
}

// On the card's own ramps (the trapezoid model: the wheels lag what they are told).
TEST_F(LoopDoorGuard, WithTheCardsRampsItStillStopsAtTheStandoff) {
  card.set_motion_model(drivers::MockMotionModel::kProfile);
  const DoorGuard guard = door_ahead(1.0);
  ASSERT_TRUE(loop->post_door_guard(guard));
  hold(0.3, 0.0, 2000);
  EXPECT_GE(distance(guard), 0.4 - 0.002);
  EXPECT_LE(distance(guard), 0.4 + 0.005);
  EXPECT_FALSE(card.any_moving());
}

TEST_F(LoopDoorGuard, AnObliqueApproachStopsAtTheStandoffToo) {
  const DoorGuard guard = door_ahead(1.0);
  ASSERT_TRUE(loop->post_door_guard(guard));
  hold(0.0, 0.5, 100);  // turn about 0.44 rad first
  hold(0.3, 0.0, 2500);
  EXPECT_GE(distance(guard), 0.4 - 0.002);
  EXPECT_LE(distance(guard), 0.4 + 0.005);
}

// A hard bound as well: a card that stops applying the jog's updates (it keeps the speed it had)
// is emergency-stopped before the base is 5 mm past the standoff.
TEST_F(LoopDoorGuard, ACardThatDoesNotSlowDownIsEmergencyStoppedAtTheStandoff) {
  const DoorGuard guard = door_ahead(0.6);  // 0.2 m of room
  ASSERT_TRUE(loop->post_door_guard(guard));
  hold(0.3, 0.0, 150);  // 0.3 s: at about 0.1 m/s, still well short of the standoff
  ASSERT_GT(distance(guard), 0.45);
  card.drop_next_calls(ajar::testing::CardCall::kJog, 1'000'000);
  for (int i = 0; i < 1000 && loop->snapshot().fault == ErrorCode::kOk; ++i) {
    if (i % 50 == 0) {
      ASSERT_TRUE(loop->post_drive({1, false, {0.3, 0.0}, now()}));
    }
    run(1);
  }
  EXPECT_EQ(loop->snapshot().fault, ErrorCode::kVelocityMismatch);
  EXPECT_FALSE(card.any_moving());
  EXPECT_GE(distance(guard), 0.4 - 0.005) << "the base went on past the standoff";
}

TEST_F(LoopDoorGuard, AStaleDistanceCapsTheForwardSpeedOnly) {
  DoorGuard guard;
  guard.mode = DoorGuard::Mode::kStale;
  guard.stale_speed_m_s = 0.05;
  ASSERT_TRUE(loop->post_door_guard(guard));
  hold(0.3, 0.0, 300);
  EXPECT_NEAR(loop->snapshot().commanded.linear_m_s, 0.05, 1e-12);
  EXPECT_TRUE(loop->snapshot().guard_limiting);
  hold(-0.3, 0.0, 600);
  EXPECT_NEAR(loop->snapshot().commanded.linear_m_s, -0.3, 1e-12) << "backing off is not capped";
}

TEST_F(LoopDoorGuard, NoDoorNoLimit) {
  hold(0.3, 0.0, 400);
  EXPECT_NEAR(loop->snapshot().commanded.linear_m_s, 0.3, 1e-12);
  EXPECT_FALSE(loop->snapshot().guard_limiting);
}

}  // namespace
}  // namespace ajar::daemon
