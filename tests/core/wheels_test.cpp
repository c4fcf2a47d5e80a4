// Wheel angles (eq. 6-7), motor counts, rounding, residual, and the odometry inverse.
#include <cstdint>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "ajar/core/geometry.hpp"
#include "test_support.hpp"

namespace ajar::core {
namespace {

using test::kPi;

// The one conversion of a wheel rotation to motor counts (wheel_command and straight_command both
// use it): rounded half away from zero, and refused at 2^53 counts, where doubles stop holding
// every integer.
TEST(WheelRadToMotorCounts, RoundsHalfAwayFromZeroAndRefusesBeyondTwoToTheFiftyThree) {
  BaseGeometry base;
  base.gear_ratio = 1;
  base.encoder_counts_per_rev = 1;  // one count per wheel revolution
  EXPECT_EQ(wheel_rad_to_motor_counts(2 * kPi * 2.4, base), 2);
  EXPECT_EQ(wheel_rad_to_motor_counts(2 * kPi * 2.6, base), 3);
  EXPECT_EQ(wheel_rad_to_motor_counts(-2 * kPi * 2.6, base), -3);
  const double two_to_53 = 9007199254740992.0;  // powers of two: 2 pi times them is exact
  EXPECT_EQ(wheel_rad_to_motor_counts(2 * kPi * (two_to_53 / 2), base),
            static_cast<std::int64_t>(two_to_53 / 2));
  EXPECT_FALSE(wheel_rad_to_motor_counts(2 * kPi * two_to_53, base));
  EXPECT_FALSE(wheel_rad_to_motor_counts(-2 * kPi * two_to_53, base));
  EXPECT_FALSE(wheel_rad_to_motor_counts(std::numeric_limits<double>::quiet_NaN(), base));
  EXPECT_FALSE(wheel_rad_to_motor_counts(std::numeric_limits<double>::infinity(), base));
}

TEST(YawFromNormal, TurnsTheBaseOntoMinusTheNormal) {
  EXPECT_DOUBLE_EQ(yaw_from_normal_rad(Vec3(-1, 0, 0)), 0.0);         // the door straight ahead
  EXPECT_NEAR(yaw_from_normal_rad(Vec3(-1, -1, 0)), kPi / 4, 1e-15);  // door to the left: CCW
  EXPECT_NEAR(yaw_from_normal_rad(Vec3(-1, 1, 0)), -kPi / 4, 1e-15);
  EXPECT_DOUBLE_EQ(yaw_from_normal_rad(Vec3(-2, 0, 5)), 0.0);  // only the floor projection counts
}

TEST(WheelCommand, EquationSevenOppositeWheels) {
  BaseGeometry base;  // R_W 0.1, R_B 0.3
  const WheelCommand ccw = wheel_command(0.1, base);
  // Turning CCW (left) rolls the right wheel forward and the left wheel backward.
  EXPECT_NEAR(ccw.right_wheel_rad, 0.3, 1e-15);
  EXPECT_NEAR(ccw.left_wheel_rad, -0.3, 1e-15);
  const WheelCommand cw = wheel_command(-0.1, base);
  EXPECT_EQ(cw.right_wheel_rad, -ccw.right_wheel_rad);
  EXPECT_EQ(cw.left_wheel_rad, -ccw.left_wheel_rad);
}

TEST(WheelCommand, CountsIncludeGearRatioCountsPerRevAndPolarity) {
  BaseGeometry base;  // gear 50, 10000 counts/rev, left polarity +1, right -1
  // One full wheel revolution: yaw = 2 pi R_W / R_B.
  const WheelCommand turn =
      wheel_command(2 * kPi * base.wheel_radius_m / base.turning_radius_m, base);
  EXPECT_EQ(turn.left_counts, -500000);   // left wheel backward, positive polarity
  EXPECT_EQ(turn.right_counts, -500000);  // right wheel forward, negative polarity
  base.left.polarity = -1;
  base.right.polarity = 1;
  const WheelCommand flipped =
      wheel_command(2 * kPi * base.wheel_radius_m / base.turning_radius_m, base);
  EXPECT_EQ(flipped.left_counts, 500000);
  EXPECT_EQ(flipped.right_counts, 500000);
}

// Rounding is half away from zero (not banker's, not floor(x + 0.5)). With 4096 counts per wheel
// revolution and R_B = R_W these yaws give exact half counts.
TEST(WheelCommand, CountsRoundHalfAwayFromZero) {
  BaseGeometry base;
  base.wheel_radius_m = 0.25;
  base.turning_radius_m = 0.25;
  base.gear_ratio = 1;
  base.encoder_counts_per_rev = 4096;
  base.left.polarity = 1;
  base.right.polarity = 1;
  struct Case {
    double half_counts;
    std::int64_t right;
  };
  for (const Case& k : {Case{0.5, 1}, Case{1.5, 2}, Case{2.5, 3}, Case{-2.5, -3}, Case{-0.5, -1},
                        Case{1000.5, 1001}, Case{2.4, 2}, Case{-2.6, -3}}) {
    const WheelCommand c = wheel_command(k.half_counts / 4096 * 2 * kPi, base);
    EXPECT_EQ(c.right_counts, k.right) << k.half_counts;
    EXPECT_EQ(c.left_counts, -k.right) << k.half_counts;
  }
}

TEST(WheelCommand, WorkedExampleCountsAndResidual) {
  const BaseGeometry base;
  const WheelCommand c = wheel_command(-0.099668652491162107, base);
  EXPECT_NEAR(c.left_wheel_rad, 0.299005957473486, 1e-14);
  EXPECT_NEAR(c.right_wheel_rad, -0.299005957473486, 1e-14);
  EXPECT_EQ(c.left_counts, 23794);   // 23794.138 rounded; left polarity +1
  EXPECT_EQ(c.right_counts, 23794);  // -23794.138 rounded, times right polarity -1
  EXPECT_NEAR(c.achieved_yaw_rad, -0.0996680741326874, 1e-15);
  EXPECT_NEAR(c.residual_yaw_rad, -5.78358474723e-07, 1e-17);
}

// Property: the residual is what rounding leaves, at most half a count's worth of yaw, and the
// achieved yaw is exactly what the odometry functions read back from the commanded counts.
TEST(WheelCommandProperty, ResidualIsAtMostHalfACount) {
  std::mt19937_64 rng(314);
  for (int trial = 0; trial < 5000; ++trial) {
    BaseGeometry base;
    base.wheel_radius_m = test::uniform(rng, 0.05, 0.2);
    base.turning_radius_m = test::uniform(rng, 0.2, 0.5);
    base.encoder_counts_per_rev =
        static_cast<double>(std::uniform_int_distribution<int>(100, 20000)(rng));
    base.gear_ratio = test::uniform(rng, 1, 100);
    base.left.polarity = trial % 2 == 0 ? 1 : -1;
    base.right.polarity = trial % 3 == 0 ? 1 : -1;
    const double yaw = test::uniform(rng, -0.7, 0.7);
    const WheelCommand c = wheel_command(yaw, base);
    const double one_count_yaw = 2 * kPi / (base.gear_ratio * base.encoder_counts_per_rev) *
                                 base.wheel_radius_m / base.turning_radius_m;
    EXPECT_LE(std::abs(c.residual_yaw_rad), one_count_yaw / 2 * (1 + 1e-9)) << trial;
    EXPECT_EQ(c.residual_yaw_rad, yaw - c.achieved_yaw_rad);
    EXPECT_EQ(c.achieved_yaw_rad, base_yaw_from_wheels_rad(
                                      counts_to_wheel_rad(c.left_counts, base.left, base),
                                      counts_to_wheel_rad(c.right_counts, base.right, base), base));
    // The wheels turn opposite ways by the same amount.
    EXPECT_EQ(c.left_counts * base.left.polarity, -c.right_counts * base.right.polarity);
    EXPECT_EQ(c.left_wheel_rad, -c.right_wheel_rad);
    EXPECT_NEAR(c.right_wheel_rad, yaw * base.turning_radius_m / base.wheel_radius_m, 1e-15);
  }
}

TEST(Odometry, CountsToWheelAngle) {
  const BaseGeometry base;  // 500000 motor counts per wheel revolution
  EXPECT_NEAR(counts_to_wheel_rad(500000, base.left, base), 2 * kPi, 1e-15);
  EXPECT_NEAR(counts_to_wheel_rad(500000, base.right, base), -2 * kPi, 1e-15);  // polarity -1
  EXPECT_NEAR(counts_to_wheel_rad(-125000, base.left, base), -kPi / 2, 1e-15);
  EXPECT_NEAR(base_yaw_from_wheels_rad(-0.3, 0.3, base), 0.1, 1e-16);
  EXPECT_EQ(base_yaw_from_wheels_rad(0.3, 0.3, base), 0.0);  // driving straight: no yaw
}

// Property: reading the encoders back and commanding that yaw gives the same counts (the daemon
// uses these for odometry, so they must invert the command path).
TEST(OdometryProperty, ExactInverseOfTheCommandPath) {
  std::mt19937_64 rng(2718);
  const BaseGeometry base;
  for (int trial = 0; trial < 5000; ++trial) {
    const std::int64_t n =
        std::uniform_int_distribution<std::int64_t>(-10'000'000, 10'000'000)(rng);
    const std::int64_t left = -n * base.left.polarity;
    const std::int64_t right = n * base.right.polarity;
    const double yaw = base_yaw_from_wheels_rad(counts_to_wheel_rad(left, base.left, base),
                                                counts_to_wheel_rad(right, base.right, base), base);
    const WheelCommand c = wheel_command(yaw, base);
    ASSERT_EQ(c.left_counts, left) << n;
    ASSERT_EQ(c.right_counts, right) << n;
    EXPECT_NEAR(c.achieved_yaw_rad, yaw, 1e-15 * (1 + std::abs(yaw)));
    EXPECT_NEAR(c.residual_yaw_rad, 0.0, 1e-15 * (1 + std::abs(yaw)));
  }
}

TEST(WheelCommand, NonFiniteOrAbsurdYawCommandsNothing) {
  const BaseGeometry base;
  for (double yaw :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e300}) {
    const WheelCommand c = wheel_command(yaw, base);
    EXPECT_EQ(c.left_counts, 0);
    EXPECT_EQ(c.right_counts, 0);
    EXPECT_EQ(c.left_wheel_rad, 0.0);
    EXPECT_EQ(c.achieved_yaw_rad, 0.0);
  }
  EXPECT_EQ(wheel_command(0.0, base).left_counts, 0);
}

}  // namespace
}  // namespace ajar::core
