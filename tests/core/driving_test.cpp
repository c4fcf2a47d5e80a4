// Driving math: body <-> wheel velocities, the speed limiter, odometry against the kinematic truth,
// rebasing measurements, the door seen after the base moved, the straight move's counts.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include <gtest/gtest.h>

#include "ajar/core/driving.hpp"
#include "test_support.hpp"

namespace ajar::core {
namespace {

using test::kPi;

TEST(WheelVelocity, DifferentialDriveBothWays) {
  BaseGeometry base;  // R_W 0.1, R_B 0.3, max wheel 1 rad/s
  base.max_wheel_speed_rad_s = 100;
  const WheelVelocity forward = wheel_velocity({0.2, 0.0}, base);
  EXPECT_DOUBLE_EQ(forward.left_rad_s, 2.0);
  EXPECT_DOUBLE_EQ(forward.right_rad_s, 2.0);
  const WheelVelocity ccw = wheel_velocity({0.0, 0.5}, base);  // right forward, left back
  EXPECT_DOUBLE_EQ(ccw.right_rad_s, 1.5);
  EXPECT_DOUBLE_EQ(ccw.left_rad_s, -1.5);
  const BodyVelocity back = body_velocity(wheel_velocity({0.13, -0.4}, base), base);
  EXPECT_NEAR(back.linear_m_s, 0.13, 1e-12);
  EXPECT_NEAR(back.angular_rad_s, -0.4, 1e-12);
}

TEST(WheelVelocity, WheelLimitScalesBothAndKeepsCurvature) {
  BaseGeometry base;
  base.max_wheel_speed_rad_s = 1.0;
  const BodyVelocity asked{0.3, 0.5};  // left 1.5, right 4.5 rad/s unlimited
  const WheelVelocity w = wheel_velocity(asked, base);
  EXPECT_DOUBLE_EQ(std::max(std::abs(w.left_rad_s), std::abs(w.right_rad_s)), 1.0);
  const BodyVelocity got = body_velocity(w, base);
  EXPECT_NEAR(got.angular_rad_s / got.linear_m_s, 0.5 / 0.3, 1e-12);  // same curvature
}

TEST(WheelVelocity, NonFiniteIsZero) {
  const WheelVelocity w = wheel_velocity({std::nan(""), INFINITY}, BaseGeometry{});
  EXPECT_EQ(w.left_rad_s, 0.0);
  EXPECT_EQ(w.right_rad_s, 0.0);
}

TEST(SpeedLimiter, ClampsSpeedThenAcceleration) {
  DriveLimits l;
  l.max_linear_speed_m_s = 0.3;
  l.max_linear_accel_m_s2 = 0.5;
  l.max_angular_speed_rad_s = 0.6;
  l.max_angular_accel_rad_s2 = 1.0;
  BodyVelocity v{};
  // From rest toward 10 m/s: 0.5 m/s^2 * 0.1 s per step, never above 0.3 m/s.
  for (int i = 1; i <= 10; ++i) {
    v = limit_velocity({10.0, -10.0}, v, 0.1, l);
    EXPECT_NEAR(v.linear_m_s, std::min(0.05 * i, 0.3), 1e-12) << i;
    EXPECT_NEAR(v.angular_rad_s, -std::min(0.1 * i, 0.6), 1e-12) << i;
  }
  // Slowing down is limited too (a smooth stop), and ends exactly at zero.
  v = limit_velocity({0.0, 0.0}, v, 0.1, l);
  EXPECT_NEAR(v.linear_m_s, 0.25, 1e-12);
  for (int i = 0; i < 20; ++i)
    v = limit_velocity({0.0, 0.0}, v, 0.1, l);
  EXPECT_EQ(v.linear_m_s, 0.0);
  EXPECT_EQ(v.angular_rad_s, 0.0);
  // NaN asks for a stop.
  const BodyVelocity from{0.3, 0.0};
  EXPECT_NEAR(limit_velocity({std::nan(""), 0.0}, from, 0.1, l).linear_m_s, 0.25, 1e-12);
}

// The kinematic truth: a constant body velocity for time t moves the base along an exact arc.
PlanarPose arc(const PlanarPose& p, double v, double w, double t) {
  if (w == 0)
    return {p.x_m + v * t * std::cos(p.yaw_rad), p.y_m + v * t * std::sin(p.yaw_rad), p.yaw_rad};
  const double r = v / w, yaw = p.yaw_rad + w * t;
  return {p.x_m + r * (std::sin(yaw) - std::sin(p.yaw_rad)),
          p.y_m - r * (std::cos(yaw) - std::cos(p.yaw_rad)), yaw};
}

TEST(Odometry, MatchesTheKinematicTruthOnRandomArcs) {
  const char* env = std::getenv("AJAR_SEED");
  const unsigned long seed = env ? std::strtoul(env, nullptr, 10) : 20261123UL;
  std::printf("Odometry seed: AJAR_SEED=%lu\n", seed);
  SCOPED_TRACE("AJAR_SEED=" + std::to_string(seed));
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> speed(-0.3, 0.3), rate(-0.8, 0.8);
  BaseGeometry base;
  base.max_wheel_speed_rad_s = 100;
  PlanarPose odom, truth;
  for (int segment = 0; segment < 20; ++segment) {
    const double v = speed(rng), w = rate(rng);
    const WheelVelocity wheels = wheel_velocity({v, w}, base);
    const double dt = 0.002;  // 500 Hz
    for (int i = 0; i < 250; ++i)
      odom = integrate_odometry(odom, wheels.left_rad_s * dt, wheels.right_rad_s * dt, base);
    truth = arc(truth, v, w, 0.5);
  }
  EXPECT_NEAR(odom.x_m, truth.x_m, 1e-6);
  EXPECT_NEAR(odom.y_m, truth.y_m, 1e-6);
  EXPECT_NEAR(odom.yaw_rad, truth.yaw_rad, 1e-9);
}

TEST(Odometry, TurnInPlaceDoesNotMoveTheOrigin) {
  BaseGeometry base;
  PlanarPose p = integrate_odometry({}, -0.3, 0.3, base);
  EXPECT_DOUBLE_EQ(p.x_m, 0.0);
  EXPECT_DOUBLE_EQ(p.y_m, 0.0);
  EXPECT_NEAR(p.yaw_rad, 0.1, 1e-15);
}

TEST(Rebase, PointSeenAfterDrivingAndTurning) {
  const PlanarPose at{0, 0, 0};
  const PlanarPose now{0.5, 0.0, kPi / 2};  // drove 0.5 m forward, then turned left 90 degrees
  const Vec3 p = rebase(Vec3(1.0, 0.0, 0.3), at, now);
  EXPECT_NEAR(p.x(), 0.0, 1e-12);
  EXPECT_NEAR(p.y(), -0.5, 1e-12);  // now on the right
  EXPECT_DOUBLE_EQ(p.z(), 0.3);
  const Vec3 back = rebase(p, now, at);
  EXPECT_NEAR(back.x(), 1.0, 1e-12);
  EXPECT_NEAR(back.y(), 0.0, 1e-12);
}

TEST(DoorView, FromPlaneFollowsTheBase) {
  Plane plane;  // door 2 m ahead, turned so that the base must turn +0.1 rad to face it
  plane.normal = Vec3(-std::cos(0.1), -std::sin(0.1), 0.0);
  plane.centroid_m = Vec3(2.0, 0.0, 0.0);
  const double d0 = -plane.normal.dot(plane.centroid_m);
  DoorView v = door_from_plane(plane, {}, {});
  EXPECT_NEAR(v.distance_m, d0, 1e-12);
  EXPECT_NEAR(v.yaw_rad, 0.1, 1e-12);
  // Turning by the yaw squares it up, without changing the distance (turn about the origin).
  v = door_from_plane(plane, {}, {0, 0, 0.1});
  EXPECT_NEAR(v.yaw_rad, 0.0, 1e-12);
  EXPECT_NEAR(v.distance_m, d0, 1e-12);
  // Then driving 0.5 m straight toward it brings it 0.5 m closer.
  v = door_from_plane(plane, {}, {0.5 * std::cos(0.1), 0.5 * std::sin(0.1), 0.1});
  EXPECT_NEAR(v.distance_m, d0 - 0.5, 1e-12);
}

TEST(DoorView, FromWidthPointsIsThePerpendicularToTheirLine) {
  // Door line at x = 1.5 + 0.1 y (not square), edges at y = +-0.45.
  const Vec3 p1(1.5 + 0.045, 0.45, 0.3), p2(1.5 - 0.045, -0.45, 0.3);
  const DoorView v = door_from_width(p1, p2, {}, {});
  EXPECT_NEAR(v.distance_m, 1.5 / std::sqrt(1.0 + 0.01), 1e-12);
  EXPECT_NEAR(v.yaw_rad, -std::atan(0.1), 1e-12);
  // Order of the points does not matter.
  EXPECT_NEAR(door_from_width(p2, p1, {}, {}).yaw_rad, v.yaw_rad, 1e-15);
}

// The door as a line in the odometry frame gives the distance DoorView gives from any pose.
TEST(DoorLine, GivesTheDistanceDoorViewGivesFromAnyPose) {
  Plane plane;
  plane.normal = Vec3(-std::cos(0.1), -std::sin(0.1), 0.02).normalized();
  plane.centroid_m = Vec3(1.8, 0.2, 0.9);
  const Vec3 p1(1.5 + 0.045, 0.45, 0.3), p2(1.5 - 0.045, -0.45, 0.3);
  const PlanarPose at{0.3, -0.2, 0.4};
  const DoorLine from_plane = door_line_from_plane(plane, at);
  const DoorLine from_width = door_line_from_width(p1, p2, at);
  EXPECT_NEAR(std::hypot(from_plane.normal_x_m, from_plane.normal_y_m),
              std::hypot(plane.normal.x(), plane.normal.y()), 1e-12);
  for (const PlanarPose now : {at, PlanarPose{0.5, -0.1, 0.35}, PlanarPose{0.9, 0.3, -0.2}}) {
    EXPECT_NEAR(door_distance_m(from_plane, now.x_m, now.y_m),
                door_from_plane(plane, at, now).distance_m, 1e-12);
    EXPECT_NEAR(door_distance_m(from_width, now.x_m, now.y_m),
                door_from_width(p1, p2, at, now).distance_m, 1e-12);
  }
}

TEST(StraightCommand, BothWheelsForwardWithPolarity) {
  BaseGeometry base;  // R_W 0.1, gear 50, 10000 counts/rev, right polarity -1
  const StraightCommand c = straight_command(2 * kPi * base.wheel_radius_m, base);  // one turn
  EXPECT_NEAR(c.wheel_rad, 2 * kPi, 1e-12);
  EXPECT_EQ(c.left_counts, 500000);
  EXPECT_EQ(c.right_counts, -500000);
  const StraightCommand none = straight_command(std::nan(""), base);
  EXPECT_EQ(none.left_counts, 0);
  EXPECT_EQ(none.right_counts, 0);
  EXPECT_EQ(straight_command(1e300, base).left_counts, 0);
}

}  // namespace
}  // namespace ajar::core
