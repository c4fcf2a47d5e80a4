// Algorithm 1 in the base frame: distance, direction of rotation, and where Ajar refuses.
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "ajar/core/geometry.hpp"
#include "test_support.hpp"

namespace ajar::core {
namespace {

using test::kTol;

TEST(Algorithm1, LengthAndDirectionFromTheSignOfY1MinusY2) {
  auto ccw = measure_span(Vec3(1.0, 0.4, 0.1), Vec3(1.2, -0.4, 0.0), kTol);
  ASSERT_TRUE(ccw.ok()) << ccw.error().message;
  EXPECT_DOUBLE_EQ(ccw->length_m, std::sqrt(0.04 + 0.64 + 0.01));
  EXPECT_EQ(ccw->direction, RotationDirection::kCounterClockwise);

  auto cw = measure_span(Vec3(1.2, -0.4, 0.0), Vec3(1.0, 0.4, 0.1), kTol);
  ASSERT_TRUE(cw.ok());
  EXPECT_DOUBLE_EQ(cw->length_m, ccw->length_m);
  EXPECT_EQ(cw->direction, RotationDirection::kClockwise);
}

// Property: a door hinged on the robot's left (P1 on the larger-y side) opens CCW; on the right CW.
TEST(Algorithm1Property, DirectionMatchesTheHingeSideForRandomDoors) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 1000; ++trial) {
    const test::Door door = test::random_door(rng, 0.7, 0.3);
    const double width = test::uniform(rng, 0.5, 1.5);
    const Vec3 left_edge = door.at(width / 2, test::uniform(rng, -0.1, 0.1));
    const Vec3 right_edge = door.at(-width / 2, test::uniform(rng, -0.1, 0.1));

    auto hinged_left = measure_span(left_edge, right_edge, kTol);
    ASSERT_TRUE(hinged_left.ok()) << trial << ": " << hinged_left.error().message;
    EXPECT_EQ(hinged_left->direction, RotationDirection::kCounterClockwise) << trial;
    EXPECT_NEAR(hinged_left->length_m, (left_edge - right_edge).norm(), 1e-15);

    auto hinged_right = measure_span(right_edge, left_edge, kTol);
    ASSERT_TRUE(hinged_right.ok()) << trial << ": " << hinged_right.error().message;
    EXPECT_EQ(hinged_right->direction, RotationDirection::kClockwise) << trial;
    EXPECT_EQ(hinged_right->length_m, hinged_left->length_m);
  }
}

TEST(Algorithm1Refuses, DuplicateAndTooClosePoints) {
  for (const Vec3& p2 : {Vec3(1.0, 0.2, 0.3), Vec3(1.0, 0.195, 0.3), Vec3(1.005, 0.2, 0.305)}) {
    auto s = measure_span(Vec3(1.0, 0.2, 0.3), p2, kTol);
    ASSERT_FALSE(s.ok()) << p2.transpose();
    EXPECT_EQ(s.error().code, ErrorCode::kPointsTooClose);
    EXPECT_EQ(s.error().field, "p2");
    EXPECT_NE(s.error().message.find("at least 0.010 m apart"), std::string::npos)
        << s.error().message;
  }
}

// Where the paper silently answers CW.
TEST(Algorithm1Refuses, SameLateralPositionIsAmbiguousNotClockwise) {
  // y1 == y2 exactly, separated in depth only, in height only, and both.
  for (const Vec3& p2 : {Vec3(2.0, 0.2, 0.3), Vec3(1.0, 0.2, 1.3), Vec3(1.5, 0.2, -0.5),
                         Vec3(1.0, 0.2 + 0.009, 1.0)}) {
    auto s = measure_span(Vec3(1.0, 0.2, 0.3), p2, kTol);
    ASSERT_FALSE(s.ok()) << p2.transpose();
    EXPECT_EQ(s.error().code, ErrorCode::kAmbiguousDirection);
    EXPECT_EQ(s.error().field, "p2");
  }
  // Just past the tolerance the direction is known (and side by side).
  auto ok = measure_span(Vec3(1.0, 0.2, 0.3), Vec3(1.0, 0.2 - 0.011, 0.3), kTol);
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->direction, RotationDirection::kCounterClockwise);
}

TEST(Algorithm1Refuses, PointsNotSideBySide) {
  // Mostly vertical (a 2 cm lateral drift over 1 m of height), mostly depth.
  for (const Vec3& p2 : {Vec3(1.0, 0.22, 1.3), Vec3(2.0, 0.1, 0.3), Vec3(1.0, -0.2, 1.0)}) {
    auto s = measure_span(Vec3(1.0, 0.2, 0.3), p2, kTol);
    ASSERT_FALSE(s.ok()) << p2.transpose();
    EXPECT_EQ(s.error().code, ErrorCode::kPointsNotSideBySide);
    EXPECT_EQ(s.error().field, "p2");
    EXPECT_NE(s.error().message.find("at least 50% sideways"), std::string::npos)
        << s.error().message;
  }
  // The fraction is a threshold: 0.6 of the distance sideways passes, 0.4 does not.
  EXPECT_TRUE(measure_span(Vec3(1, 0, 0), Vec3(1, 0.6, 0.8), kTol).ok());
  EXPECT_FALSE(measure_span(Vec3(1, 0, 0), Vec3(1, 0.4, std::sqrt(0.84)), kTol).ok());
  Tolerances loose = kTol;
  loose.min_lateral_fraction = 0.3;
  EXPECT_TRUE(measure_span(Vec3(1, 0, 0), Vec3(1, 0.4, std::sqrt(0.84)), loose).ok());
}

TEST(Algorithm1Refuses, NonFiniteInEveryCoordinate) {
  const char* names[] = {"x", "y", "z"};
  for (double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
        -std::numeric_limits<double>::infinity()}) {
    for (int which = 0; which < 2; ++which) {
      for (int axis = 0; axis < 3; ++axis) {
        Vec3 p1(1.0, 0.4, 0.0);
        Vec3 p2(1.0, -0.4, 0.0);
        (which == 0 ? p1 : p2)[axis] = bad;
        auto s = measure_span(p1, p2, kTol);
        ASSERT_FALSE(s.ok());
        EXPECT_EQ(s.error().code, ErrorCode::kNonFinite);
        EXPECT_EQ(s.error().field, std::string(which == 0 ? "p1." : "p2.") + names[axis]);
      }
    }
  }
}

}  // namespace
}  // namespace ajar::core
