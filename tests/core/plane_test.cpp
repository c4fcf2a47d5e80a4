// Door plane (eq. 3-4 and least squares) and the signed yaw deviation.
#include <algorithm>
#include <array>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "ajar/core/geometry.hpp"
#include "test_support.hpp"

namespace ajar::core {
namespace {

using test::kPi;
using test::kTol;

double yaw_of(const Result<Plane>& plane) {
  EXPECT_TRUE(plane.ok()) << plane.error().message;
  if (!plane.ok()) return std::numeric_limits<double>::quiet_NaN();
  auto yaw = yaw_deviation_rad(*plane, kTol);
  EXPECT_TRUE(yaw.ok()) << yaw.error().message;
  return yaw.ok() ? *yaw : std::numeric_limits<double>::quiet_NaN();
}

TEST(ThreePointPlane, NormalIsTheCrossProductOrientedTowardTheRobot) {
  // A door 1 m ahead, square to the robot: the plane x = 1.
  const Vec3 a(1, 0.3, 0), b(1, -0.3, 0), c(1, 0, 0.5);
  for (const auto& [p, q, r] : {std::array{a, b, c}, std::array{a, c, b}}) {
    auto plane = plane_from_three_points(p, q, r, kTol);
    ASSERT_TRUE(plane.ok()) << plane.error().message;
    EXPECT_TRUE(plane->normal.isApprox(-Vec3::UnitX(), 1e-15)) << plane->normal.transpose();
    EXPECT_TRUE(plane->centroid_m.isApprox(Vec3(1, 0, 0.5 / 3), 1e-15));
    EXPECT_EQ(plane->rms_residual_m, 0.0);
  }
  // Behind the robot the normal faces forward (+x): still toward the robot.
  auto behind = plane_from_three_points(-a, -b, -c, kTol);
  ASSERT_TRUE(behind.ok());
  EXPECT_TRUE(behind->normal.isApprox(Vec3::UnitX(), 1e-15));
}

TEST(SignedYaw, SignConvention) {
  // The door's left side (larger y) is further away: the base must turn clockwise (negative).
  auto right_turn =
      plane_from_three_points(Vec3(1.1, 0.5, 0), Vec3(0.9, -0.5, 0), Vec3(1.0, 0.0, 0.5), kTol);
  EXPECT_NEAR(yaw_of(right_turn), -std::atan(0.2), 1e-15);
  // Mirror image: turn counter-clockwise (positive).
  auto left_turn =
      plane_from_three_points(Vec3(0.9, 0.5, 0), Vec3(1.1, -0.5, 0), Vec3(1.0, 0.0, 0.5), kTol);
  EXPECT_NEAR(yaw_of(left_turn), std::atan(0.2), 1e-15);
}

// Property: random doors at random yaw and tilt within limits; every one of the 6 pick orders of
// three points, and the least-squares fit of the same three, recover the yaw to 1e-9.
TEST(SignedYawProperty, ThreePointsEveryPickOrder) {
  std::mt19937_64 rng(42);
  for (int trial = 0; trial < 2000; ++trial) {
    const test::Door door = test::random_door(rng, 0.7, 0.3);
    std::array<Vec3, 3> p = test::random_triangle(rng, door);
    std::array<int, 3> order{0, 1, 2};
    int permutations = 0;
    do {
      const Vec3& a = p[static_cast<std::size_t>(order[0])];
      const Vec3& b = p[static_cast<std::size_t>(order[1])];
      const Vec3& c = p[static_cast<std::size_t>(order[2])];
      auto three = plane_from_three_points(a, b, c, kTol);
      ASSERT_NEAR(yaw_of(three), door.yaw_rad, 1e-9) << "trial " << trial;
      EXPECT_NEAR(three->normal.dot(-door.into_door), 1.0, 1e-12);
      const std::array<Vec3, 3> ordered{a, b, c};
      auto fitted = fit_plane(ordered, kTol);
      ASSERT_NEAR(yaw_of(fitted), door.yaw_rad, 1e-9) << "trial " << trial;
      EXPECT_TRUE(fitted->normal.isApprox(three->normal, 1e-12));
      ++permutations;
    } while (std::next_permutation(order.begin(), order.end()));
    EXPECT_EQ(permutations, 6);
  }
}

// Property: N = 4..16 points on random doors; shuffled pick orders give the same yaw (1e-9), the
// true yaw, and a zero residual.
TEST(SignedYawProperty, LeastSquaresAnyShuffle) {
  std::mt19937_64 rng(4242);
  for (int trial = 0; trial < 300; ++trial) {
    const test::Door door = test::random_door(rng, 0.7, 0.3);
    const int n = 4 + trial % 13;
    std::vector<Vec3> p = test::random_points(rng, door, n);
    for (int shuffle = 0; shuffle < 6; ++shuffle) {
      std::shuffle(p.begin(), p.end(), rng);
      auto plane = fit_plane(p, kTol);
      ASSERT_NEAR(yaw_of(plane), door.yaw_rad, 1e-9) << "trial " << trial << " n " << n;
      EXPECT_LT(plane->rms_residual_m, 1e-12);
    }
  }
}

// With measurement noise the answer is no longer exact, but it still does not depend on order,
// and the residual is the RMS of the point-to-plane distances.
TEST(SignedYawProperty, NoisyPointsOrderIndependentWithResidual) {
  std::mt19937_64 rng(99);
  std::normal_distribution<double> noise(0.0, 0.003);
  for (int trial = 0; trial < 100; ++trial) {
    const test::Door door = test::random_door(rng, 0.6, 0.2);
    std::vector<Vec3> p = test::random_points(rng, door, 8);
    for (Vec3& v : p)
      v += noise(rng) * door.into_door;
    auto reference = fit_plane(p, kTol);
    const double yaw = yaw_of(reference);
    EXPECT_NEAR(yaw, door.yaw_rad, 0.05);
    double sum_sq = 0;
    for (const Vec3& v : p)
      sum_sq += std::pow((v - reference->centroid_m).dot(reference->normal), 2);
    EXPECT_NEAR(reference->rms_residual_m, std::sqrt(sum_sq / 8.0), 1e-15);
    EXPECT_GT(reference->rms_residual_m, 1e-4);
    for (int shuffle = 0; shuffle < 4; ++shuffle) {
      std::shuffle(p.begin(), p.end(), rng);
      auto again = fit_plane(p, kTol);
      EXPECT_NEAR(yaw_of(again), yaw, 1e-9);
      EXPECT_NEAR(again->rms_residual_m, reference->rms_residual_m, 1e-12);
    }
  }
}

TEST(PlaneRefuses, DuplicateOrTooClosePointsNameTheLaterPoint) {
  const Vec3 a(1, 0.3, 0), b(1, -0.3, 0), c(1, 0, 0.5);
  struct Case {
    std::array<Vec3, 3> points;
    const char* field;
  };
  const Case cases[] = {{{a, a, c}, "points[1]"},
                        {{a, b, b}, "points[2]"},
                        {{a, b, a + Vec3(0, 0.005, 0.005)}, "points[2]"},
                        {{c, a, c}, "points[2]"}};
  for (const Case& k : cases) {
    auto three = plane_from_three_points(k.points[0], k.points[1], k.points[2], kTol);
    ASSERT_FALSE(three.ok());
    EXPECT_EQ(three.error().code, ErrorCode::kPointsTooClose);
    EXPECT_EQ(three.error().field, k.field);
    auto fitted = fit_plane(k.points, kTol);
    ASSERT_FALSE(fitted.ok());
    EXPECT_EQ(fitted.error().field, k.field);
  }
  // N points: a duplicate at index 4 of 5.
  const std::vector<Vec3> five{a, b, c, Vec3(1, 0.2, 0.4), b};
  auto fitted = fit_plane(five, kTol);
  ASSERT_FALSE(fitted.ok());
  EXPECT_EQ(fitted.error().code, ErrorCode::kPointsTooClose);
  EXPECT_EQ(fitted.error().field, "points[4]");
  EXPECT_NE(fitted.error().message.find("from points[1]"), std::string::npos)
      << fitted.error().message;
}

TEST(PlaneRefuses, CollinearPoints) {
  const Vec3 a(1, 0.3, 0), b(1, -0.3, 0);
  auto exact = plane_from_three_points(a, b, (a + b) / 2, kTol);
  ASSERT_FALSE(exact.ok());
  EXPECT_EQ(exact.error().code, ErrorCode::kPointsCollinear);
  EXPECT_EQ(exact.error().field, "points");
  const std::vector<Vec3> row{a, b, Vec3(1, 0.1, 0), Vec3(1, -0.1, 0.001)};
  auto fitted = fit_plane(row, kTol);
  ASSERT_FALSE(fitted.ok());
  EXPECT_EQ(fitted.error().code, ErrorCode::kPointsCollinear);
}

// The measure is scale-aware: the same shape is refused (or accepted) at 0.3 m and at 3 m.
TEST(PlaneRefuses, CollinearityIsScaleAware) {
  for (double scale : {0.3, 1.0, 3.0}) {
    const Vec3 a = Vec3(1, 0, 0) + scale * Vec3(0, 0.5, 0);
    const Vec3 b = Vec3(1, 0, 0) + scale * Vec3(0, -0.5, 0);
    const Vec3 thin = Vec3(1, 0, 0) + scale * Vec3(0, 0.1, 0.015);  // height / length 0.015
    const Vec3 fat = Vec3(1, 0, 0) + scale * Vec3(0, 0.1, 0.03);    // height / length 0.03
    auto refused = plane_from_three_points(a, b, thin, kTol);
    ASSERT_FALSE(refused.ok()) << scale;
    EXPECT_EQ(refused.error().code, ErrorCode::kPointsCollinear);
    EXPECT_TRUE(plane_from_three_points(a, b, fat, kTol).ok()) << scale;
    const std::vector<Vec3> thin4{a, b, thin, Vec3(1, 0, 0) + scale * Vec3(0, -0.2, 0.005)};
    EXPECT_FALSE(fit_plane(thin4, kTol).ok()) << scale;
    const std::vector<Vec3> fat4{a, b, Vec3(1, 0, 0) + scale * Vec3(0, 0.1, 0.2),
                                 Vec3(1, 0, 0) + scale * Vec3(0, -0.2, -0.2)};
    EXPECT_TRUE(fit_plane(fat4, kTol).ok()) << scale;
  }
}

TEST(PlaneRefuses, TooFewPointsAndNonFiniteInEveryCoordinate) {
  const std::vector<Vec3> two{Vec3(1, 0.3, 0), Vec3(1, -0.3, 0)};
  auto few = fit_plane(two, kTol);
  ASSERT_FALSE(few.ok());
  EXPECT_EQ(few.error().code, ErrorCode::kBadCount);

  const char* axes[] = {"x", "y", "z"};
  for (std::size_t n : {3u, 5u}) {
    for (std::size_t i = 0; i < n; ++i) {
      for (int axis = 0; axis < 3; ++axis) {
        std::vector<Vec3> p{Vec3(1, 0.3, 0), Vec3(1, -0.3, 0), Vec3(1, 0, 0.5), Vec3(1, 0.2, -0.4),
                            Vec3(1, -0.2, -0.4)};
        p.resize(n);
        p[i][axis] = std::numeric_limits<double>::quiet_NaN();
        auto fitted = fit_plane(p, kTol);
        ASSERT_FALSE(fitted.ok());
        EXPECT_EQ(fitted.error().code, ErrorCode::kNonFinite);
        EXPECT_EQ(fitted.error().field, "points[" + std::to_string(i) + "]." + axes[axis]);
      }
    }
  }
}

TEST(SignedYawRefuses, TiltedPlane) {
  // Within the tilt limit: accepted, and the yaw is the floor projection's.
  const test::Door leaning = test::make_door(0.2, 0.34, Vec3(1, 0, 0));
  auto ok =
      plane_from_three_points(leaning.at(0.3, 0), leaning.at(-0.3, 0), leaning.at(0, 0.5), kTol);
  EXPECT_NEAR(yaw_of(ok), 0.2, 1e-12);
  // Beyond it (0.36 > 0.35 rad), and the floor itself.
  for (double tilt : {0.36, -0.36, kPi / 2 - 0.01}) {
    const test::Door d = test::make_door(0.2, tilt, Vec3(1, 0, 0));
    auto plane = plane_from_three_points(d.at(0.3, 0), d.at(-0.3, 0), d.at(0, 0.5), kTol);
    ASSERT_TRUE(plane.ok());
    auto yaw = yaw_deviation_rad(*plane, kTol);
    ASSERT_FALSE(yaw.ok()) << tilt;
    EXPECT_EQ(yaw.error().code, ErrorCode::kPlaneNotVertical);
    EXPECT_EQ(yaw.error().field, "points");
    EXPECT_NE(yaw.error().message.find("at most 0.350 rad"), std::string::npos)
        << yaw.error().message;
  }
  auto floor =
      plane_from_three_points(Vec3(1, 0.3, -0.3), Vec3(1, -0.3, -0.3), Vec3(1.5, 0, -0.3), kTol);
  ASSERT_TRUE(floor.ok());
  EXPECT_EQ(yaw_deviation_rad(*floor, kTol).error().code, ErrorCode::kPlaneNotVertical);
}

TEST(SignedYawRefuses, DoorNotFacingTheFrontOfTheRobot) {
  // A wall beside the robot, parallel to its heading: squaring up would take a quarter turn.
  auto side = plane_from_three_points(Vec3(0.5, 1, 0), Vec3(1.5, 1, 0), Vec3(1, 1, 0.5), kTol);
  ASSERT_TRUE(side.ok());
  auto yaw = yaw_deviation_rad(*side, kTol);
  ASSERT_FALSE(yaw.ok());
  EXPECT_EQ(yaw.error().code, ErrorCode::kYawOutOfRange);
  // A door behind the robot.
  auto behind =
      plane_from_three_points(Vec3(-1, 0.3, 0), Vec3(-1, -0.3, 0), Vec3(-1, 0, 0.5), kTol);
  ASSERT_TRUE(behind.ok());
  EXPECT_EQ(yaw_deviation_rad(*behind, kTol).error().code, ErrorCode::kYawOutOfRange);
}

TEST(SignedYawRefuses, NonFiniteOrZeroNormal) {
  Plane p;
  p.normal = Vec3::Zero();
  EXPECT_EQ(yaw_deviation_rad(p, kTol).error().code, ErrorCode::kNonFinite);
  p.normal = Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  EXPECT_EQ(yaw_deviation_rad(p, kTol).error().code, ErrorCode::kNonFinite);
}

// The paper's eq. 5 (arccos of n_d's y component) on the worked example's points: it depends on
// the pick order and cannot tell a door from its mirror image. docs/geometry.md shows these
// numbers.
TEST(PaperEquationFive, IsUnsignedAndOrderDependent) {
  const auto eq5 = [](const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 n = (b - a).cross(c - a);
    return std::acos(n.y() / n.norm());
  };
  const Vec3 a(0.95, 0.315, -0.32), b(0.89, -0.285, -0.32), c(0.92, 0.015, -0.02);
  EXPECT_NEAR(eq5(a, b, c), 1.471127674, 1e-9);
  EXPECT_NEAR(eq5(a, c, b), 1.670464979, 1e-9);
  const auto mirror = [](const Vec3& v) { return Vec3(v.x(), 0.03 - v.y(), v.z()); };
  EXPECT_NEAR(eq5(mirror(a), mirror(b), mirror(c)), 1.471127674, 1e-9);
  // Ajar: one signed answer per door, whatever the order; opposite for the mirror image.
  const double yaw = yaw_of(plane_from_three_points(a, b, c, kTol));
  EXPECT_NEAR(yaw, -0.099668652491162, 1e-12);
  EXPECT_NEAR(yaw_of(plane_from_three_points(a, c, b, kTol)), yaw, 1e-15);
  EXPECT_NEAR(yaw_of(plane_from_three_points(mirror(a), mirror(b), mirror(c), kTol)), -yaw, 1e-12);
}

}  // namespace
}  // namespace ajar::core
