// The whole validated operations the daemon calls per request, including the worked example of
// docs/geometry.md (same numbers).
#include <array>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ajar/core/measurements.hpp"
#include "test_support.hpp"

namespace ajar::core {
namespace {

using test::kInf;
using test::kNaN;

using test::paper;

FramedPoint cam(double x, double y, double z) {
  return {Frame::kCamera, Vec3(x, y, z)};
}

// The worked example's limits: defaults, with an arm workspace that fits the paper's frames.
Limits example_limits() {
  Limits l;
  l.arm.shoulder_m = Vec3(0.30, 0.0, -0.10);
  l.arm.min_reach_m = 0.15;
  l.arm.max_reach_m = 0.85;
  l.arm.min_z_m = -0.6;
  l.arm.max_z_m = 0.6;
  return l;
}

// ---- docs/geometry.md, "Worked example" ------------------------------------------------------

TEST(WorkedExample, DoorWidth) {
  auto w =
      measure_door_width(cam(-0.40, 0.05, 1.50), cam(0.42, 0.05, 1.56), paper(), example_limits());
  ASSERT_TRUE(w.ok()) << w.error().message;
  EXPECT_TRUE(w->p1_base_m.isApprox(Vec3(1.65, 0.415, -0.27), 1e-12));
  EXPECT_TRUE(w->p2_base_m.isApprox(Vec3(1.71, -0.405, -0.27), 1e-12));
  EXPECT_NEAR(w->span.length_m, 0.822192191643779, 1e-12);
  EXPECT_EQ(w->span.direction, RotationDirection::kCounterClockwise);  // hinged on the left
}

TEST(WorkedExample, HandleLength) {
  auto h = measure_handle(cam(0.28, 0.10, 0.74), cam(0.16, 0.10, 0.745), paper(), example_limits());
  ASSERT_TRUE(h.ok()) << h.error().message;
  EXPECT_NEAR(h->span.length_m, 0.120104121494643, 1e-12);
  EXPECT_EQ(h->span.direction, RotationDirection::kClockwise);
}

TEST(WorkedExample, DoorPlaneYawAndWheels) {
  const std::array<FramedPoint, 3> points{cam(-0.30, 0.10, 0.80), cam(0.30, 0.10, 0.74),
                                          cam(0.00, -0.20, 0.77)};
  const BaseGeometry base;
  auto m = measure_door_plane(points, paper(), example_limits(), base);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->point_count, 3);
  EXPECT_TRUE(m->plane.normal.isApprox(Vec3(-1, 0.1, 0).normalized(), 1e-12))
      << m->plane.normal.transpose();
  EXPECT_NEAR(m->yaw_deviation_rad, -std::atan(0.1), 1e-12);  // -0.0996687 rad = -5.7106 deg
  EXPECT_EQ(m->wheels.left_counts, 23794);
  EXPECT_EQ(m->wheels.right_counts, 23794);
  EXPECT_NEAR(m->wheels.left_wheel_rad, 0.299005957473486, 1e-12);
  EXPECT_NEAR(m->wheels.residual_yaw_rad, -5.7836e-07, 1e-10);
  // Every pick order gives the same answer.
  std::array<int, 3> order{0, 1, 2};
  while (std::next_permutation(order.begin(), order.end())) {
    const std::array<FramedPoint, 3> shuffled{points[static_cast<std::size_t>(order[0])],
                                              points[static_cast<std::size_t>(order[1])],
                                              points[static_cast<std::size_t>(order[2])]};
    auto again = measure_door_plane(shuffled, paper(), example_limits(), base);
    ASSERT_TRUE(again.ok());
    EXPECT_NEAR(again->yaw_deviation_rad, m->yaw_deviation_rad, 1e-15);
    EXPECT_EQ(again->wheels.left_counts, 23794);
  }
}

TEST(WorkedExample, ContactPoint) {
  auto c = measure_contact_point(cam(0.18, 0.12, 0.62), paper(), example_limits());
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_TRUE(c->contact_base_m.isApprox(Vec3(0.77, -0.165, -0.34), 1e-12));
  EXPECT_NEAR(c->reach_margin_m, 0.26, 1e-12);  // 0.26 m above the bottom of the z band
}

// ---- Properties through the whole operation --------------------------------------------------

// Random doors in front of the robot, picked in the camera frame of the paper's transform, every
// pick order and random subsets of 3..16 points: the yaw comes back to 1e-9.
TEST(MeasureDoorPlaneProperty, RandomDoorsInCameraFrame) {
  std::mt19937_64 rng(1234);
  const CameraToBase t = paper();
  Limits limits;
  limits.max_yaw_correction_rad = 0.75;
  const BaseGeometry base;
  for (int trial = 0; trial < 300; ++trial) {
    const test::Door door = test::random_door(rng, 0.7, 0.3);
    const int n = 3 + trial % 14;
    std::vector<Vec3> base_points = test::random_points(rng, door, n);
    std::vector<FramedPoint> picked;
    for (const Vec3& p : base_points) {
      // Alternate frames: the host may send either.
      picked.push_back(picked.size() % 2 == 0 ? FramedPoint{Frame::kCamera, t.to_camera(p)}
                                              : FramedPoint{Frame::kBase, p});
    }
    for (int shuffle = 0; shuffle < 4; ++shuffle) {
      std::shuffle(picked.begin(), picked.end(), rng);
      auto m = measure_door_plane(picked, t, limits, base);
      ASSERT_TRUE(m.ok()) << "trial " << trial << ": " << m.error().message;
      EXPECT_NEAR(m->yaw_deviation_rad, door.yaw_rad, 1e-9) << "trial " << trial;
      EXPECT_EQ(m->point_count, n);
      const WheelCommand expected = wheel_command(m->yaw_deviation_rad, base);
      EXPECT_EQ(m->wheels.left_counts, expected.left_counts);
      EXPECT_EQ(m->wheels.right_counts, expected.right_counts);
    }
  }
}

// Random doors hinged left or right, measured from camera picks: CCW iff hinged on the left.
TEST(MeasureDoorWidthProperty, DirectionMatchesHingeSide) {
  std::mt19937_64 rng(555);
  const CameraToBase t = paper();
  for (int trial = 0; trial < 500; ++trial) {
    // One draw per statement (test_support.hpp, uniform_vec3), in x86-64's order.
    const Vec3 centre_m = test::uniform_vec3(rng, Vec3(1.6, -0.3, -0.2), Vec3(2.5, 0.3, 0.4));
    const double tilt_rad = test::uniform(rng, -0.2, 0.2);
    const double yaw_rad = test::uniform(rng, -0.7, 0.7);
    const test::Door door = test::make_door(yaw_rad, tilt_rad, centre_m);
    const double width = test::uniform(rng, 0.6, 1.1);
    const FramedPoint left{Frame::kCamera, t.to_camera(door.at(width / 2, 0.0))};
    const FramedPoint right{Frame::kCamera, t.to_camera(door.at(-width / 2, 0.05))};
    auto l = measure_door_width(left, right, t, Limits{});
    ASSERT_TRUE(l.ok()) << l.error().message;
    EXPECT_EQ(l->span.direction, RotationDirection::kCounterClockwise);
    auto r = measure_door_width(right, left, t, Limits{});
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->span.direction, RotationDirection::kClockwise);
    EXPECT_NEAR(l->span.length_m, std::hypot(width, 0.05), 1e-12);
  }
}

// ---- Every degenerate input, with the request's field names ----------------------------------

TEST(MeasureRefuses, NonFiniteInEveryCoordinateOfEveryPoint) {
  const CameraToBase t = paper();
  const char* axes[] = {"x", "y", "z"};
  for (double bad : {kNaN, kInf, -kInf}) {
    for (int axis = 0; axis < 3; ++axis) {
      for (Frame frame : {Frame::kCamera, Frame::kBase}) {
        FramedPoint good1{Frame::kCamera, Vec3(-0.4, 0.0, 1.5)};
        FramedPoint good2{Frame::kCamera, Vec3(0.4, 0.0, 1.5)};
        FramedPoint broken{frame, Vec3(0.1, 0.1, 1.5)};
        broken.position_m[axis] = bad;
        auto w1 = measure_door_width(broken, good2, t, Limits{});
        ASSERT_FALSE(w1.ok());
        EXPECT_EQ(w1.error().code, ErrorCode::kNonFinite);
        EXPECT_EQ(w1.error().field, std::string("p1.") + axes[axis]);
        auto w2 = measure_handle(good1, broken, t, Limits{});
        ASSERT_FALSE(w2.ok());
        EXPECT_EQ(w2.error().field, std::string("p2.") + axes[axis]);
        auto c = measure_contact_point(broken, t, Limits{});
        ASSERT_FALSE(c.ok());
        EXPECT_EQ(c.error().code, ErrorCode::kNonFinite);
        EXPECT_EQ(c.error().field, std::string("contact.") + axes[axis]);
        std::array<FramedPoint, 4> plane{cam(-0.3, 0.1, 0.8), cam(0.3, 0.1, 0.74),
                                         cam(0.0, -0.2, 0.77), broken};
        auto p = measure_door_plane(plane, t, Limits{}, BaseGeometry{});
        ASSERT_FALSE(p.ok());
        EXPECT_EQ(p.error().code, ErrorCode::kNonFinite);
        EXPECT_EQ(p.error().field, std::string("points[3].") + axes[axis]);
      }
    }
  }
}

TEST(MeasureRefuses, OutOfDepthAndUnknownFrame) {
  const CameraToBase t = paper();
  auto near = measure_door_width(cam(-0.4, 0, 1.5), cam(0.4, 0, 0.3), t, Limits{});
  ASSERT_FALSE(near.ok());
  EXPECT_EQ(near.error().code, ErrorCode::kPointOutOfDepthRange);
  EXPECT_EQ(near.error().field, "p2");
  auto far = measure_contact_point(cam(0, 0, 5.0), t, Limits{});
  EXPECT_EQ(far.error().code, ErrorCode::kPointOutOfDepthRange);
  EXPECT_EQ(far.error().field, "contact");
  // A base point 0.3 m ahead of the turning centre is 0.15 m from the camera: too near.
  const std::array<FramedPoint, 3> plane{
      cam(-0.3, 0.1, 0.8), FramedPoint{Frame::kBase, Vec3(0.3, 0, 0)}, cam(0.0, -0.2, 0.77)};
  auto p = measure_door_plane(plane, t, Limits{}, BaseGeometry{});
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kPointOutOfDepthRange);
  EXPECT_EQ(p.error().field, "points[1]");
  auto unknown = measure_handle(cam(0.28, 0.1, 0.74),
                                FramedPoint{static_cast<Frame>(9), Vec3(0, 0, 1)}, t, Limits{});
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::kUnknownFrame);
  EXPECT_EQ(unknown.error().field, "p2.frame");
}

TEST(MeasureRefuses, Algorithm1Degeneracies) {
  const CameraToBase t = paper();
  // Camera x is base -y: equal camera x means y1 == y2.
  auto same_y = measure_door_width(cam(0.1, -0.3, 1.5), cam(0.1, 0.4, 1.5), t, Limits{});
  EXPECT_EQ(same_y.error().code, ErrorCode::kAmbiguousDirection);
  auto dup = measure_handle(cam(0.1, 0.1, 1.0), cam(0.1, 0.1, 1.0), t, Limits{});
  EXPECT_EQ(dup.error().code, ErrorCode::kPointsTooClose);
  auto vertical = measure_door_width(cam(0.1, -0.5, 1.5), cam(0.12, 0.5, 1.5), t, Limits{});
  EXPECT_EQ(vertical.error().code, ErrorCode::kPointsNotSideBySide);
  EXPECT_EQ(vertical.error().field, "p2");
}

TEST(MeasureRefuses, WidthAndHandleOutOfRange) {
  const CameraToBase t = paper();
  auto narrow = measure_door_width(cam(-0.2, 0, 1.5), cam(0.2, 0, 1.5), t, Limits{});
  ASSERT_FALSE(narrow.ok());
  EXPECT_EQ(narrow.error().code, ErrorCode::kWidthOutOfRange);
  EXPECT_EQ(narrow.error().field, "width_m");
  EXPECT_EQ(narrow.error().message,
            "door width 0.400 m is outside the allowed range 0.500..2.000 m");
  // The same two points are a fine handle only if short enough: 0.4 m is not.
  auto handle = measure_handle(cam(-0.2, 0, 1.5), cam(0.2, 0, 1.5), t, Limits{});
  ASSERT_FALSE(handle.ok());
  EXPECT_EQ(handle.error().code, ErrorCode::kHandleLengthOutOfRange);
  EXPECT_EQ(handle.error().field, "handle_length_m");
  EXPECT_TRUE(measure_handle(cam(-0.05, 0, 0.8), cam(0.05, 0, 0.8), t, Limits{}).ok());
}

TEST(MeasureRefuses, PlaneCountsAndDegeneracies) {
  const CameraToBase t = paper();
  const BaseGeometry base;
  const std::array<FramedPoint, 2> two{cam(-0.3, 0.1, 0.8), cam(0.3, 0.1, 0.74)};
  auto few = measure_door_plane(two, t, Limits{}, base);
  EXPECT_EQ(few.error().code, ErrorCode::kBadCount);
  EXPECT_EQ(few.error().field, "points");
  std::vector<FramedPoint> many;
  for (int i = 0; i < 17; ++i)
    many.push_back(cam(0.05 * i - 0.4, 0.02 * (i % 5), 1.0));
  EXPECT_EQ(measure_door_plane(many, t, Limits{}, base).error().code, ErrorCode::kBadCount);

  const std::array<FramedPoint, 3> dup{cam(-0.3, 0.1, 0.8), cam(0.3, 0.1, 0.74),
                                       cam(-0.3, 0.1, 0.8)};
  auto d = measure_door_plane(dup, t, Limits{}, base);
  EXPECT_EQ(d.error().code, ErrorCode::kPointsTooClose);
  EXPECT_EQ(d.error().field, "points[2]");
  const std::array<FramedPoint, 3> row{cam(-0.3, 0.1, 0.8), cam(0.3, 0.1, 0.8), cam(0.0, 0.1, 0.8)};
  EXPECT_EQ(measure_door_plane(row, t, Limits{}, base).error().code, ErrorCode::kPointsCollinear);
  // The floor seen from the camera: y (down) fixed, depth varying.
  const std::array<FramedPoint, 3> floor{cam(-0.3, 0.5, 0.8), cam(0.3, 0.5, 0.8),
                                         cam(0.0, 0.5, 1.6)};
  EXPECT_EQ(measure_door_plane(floor, t, Limits{}, base).error().code,
            ErrorCode::kPlaneNotVertical);
  // A door at 0.8 rad: vertical, fine as a plane, but beyond the 0.7 rad maximum correction.
  const test::Door skew = test::make_door(0.8, 0.0, Vec3(1.2, 0, 0));
  const std::array<FramedPoint, 3> skewed{FramedPoint{Frame::kBase, skew.at(0.3, 0)},
                                          FramedPoint{Frame::kBase, skew.at(-0.3, 0)},
                                          FramedPoint{Frame::kBase, skew.at(0, 0.4)}};
  auto y = measure_door_plane(skewed, t, Limits{}, base);
  ASSERT_FALSE(y.ok());
  EXPECT_EQ(y.error().code, ErrorCode::kYawOutOfRange);
  EXPECT_EQ(y.error().field, "yaw_deviation_rad");
}

TEST(MeasureRefuses, PlaneResidualTooLarge) {
  const CameraToBase t = paper();
  // Four corners of a square at depth 1 m with one 12 cm deeper (a handle, a frame): the best
  // plane leaves each corner about 3 cm off.
  const std::array<FramedPoint, 4> bumpy{cam(-0.3, -0.3, 1.0), cam(0.3, -0.3, 1.0),
                                         cam(0.3, 0.3, 1.0), cam(-0.3, 0.3, 1.12)};
  auto m = measure_door_plane(bumpy, t, Limits{}, BaseGeometry{});
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.error().code, ErrorCode::kPlaneResidualTooLarge);
  EXPECT_EQ(m.error().field, "rms_residual_m");
  EXPECT_NE(m.error().message.find("0.0297 m (RMS)"), std::string::npos) << m.error().message;
  // The same with 1 cm is within the 2 cm allowed.
  const std::array<FramedPoint, 4> flat{cam(-0.3, -0.3, 1.0), cam(0.3, -0.3, 1.0),
                                        cam(0.3, 0.3, 1.0), cam(-0.3, 0.3, 1.01)};
  auto ok = measure_door_plane(flat, t, Limits{}, BaseGeometry{});
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_NEAR(ok->plane.rms_residual_m, 0.0025, 1e-6);  // d / 4, less a little for the tilt
}

TEST(MeasureRefuses, ContactOutOfReach) {
  const CameraToBase t = paper();
  const Limits limits = example_limits();
  // Too far: 1.5 m ahead.
  auto far = measure_contact_point(cam(0.0, 0.12, 1.5), t, limits);
  ASSERT_FALSE(far.ok());
  EXPECT_EQ(far.error().code, ErrorCode::kOutOfReach);
  EXPECT_EQ(far.error().field, "contact");
  // Too low: below the z band (camera y is down; base z = -y - 0.22).
  auto low = measure_contact_point(cam(0.0, 0.5, 0.5), t, limits);
  EXPECT_EQ(low.error().code, ErrorCode::kOutOfReach);
  EXPECT_TRUE(measure_contact_point(cam(0.0, 0.0, 0.6), t, limits).ok());
}

}  // namespace
}  // namespace ajar::core
