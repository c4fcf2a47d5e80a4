// Picks that know their pose and the geometry guidance
// (console/include/ajar/console/pick_pose.hpp): the daemon's staleness rule applied to picks, the
// point seen from a new pose, where a landmark leaves the view on a straight approach, the default
// standoff, the hinge cross-check, the plane fit.
#include "ajar/console/pick_pose.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace ajar::console {
namespace {

constexpr StaleRule kRule{0.05, 0.05};  // config/ajard.yaml's drive.stale_travel_m / stale_yaw_rad

// A camera at the base origin looking along base +x: camera z = base x, camera x = -base y,
// camera y = -base z.
core::CameraToBase forward_camera() {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.block<3, 3>(0, 0) << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return *core::CameraToBase::from_matrix(t);
}

TEST(PickMotion, TheDaemonsRuleEitherThreshold) {
  const core::PlanarPose at{1.0, 2.0, 0.3};
  EXPECT_EQ(pick_motion(at, at, kRule).place, PickPlace::kHere);
  EXPECT_EQ(pick_motion(at, {1.0003, 2.0, 0.3}, kRule).place, PickPlace::kHere);  // quantisation
  EXPECT_EQ(pick_motion(at, {1.03, 2.0, 0.3}, kRule).place, PickPlace::kMoved);
  EXPECT_EQ(pick_motion(at, {1.0, 2.04, 0.3}, kRule).place, PickPlace::kMoved);
  EXPECT_EQ(pick_motion(at, {1.0, 2.0, 0.34}, kRule).place, PickPlace::kMoved);
  EXPECT_EQ(pick_motion(at, {1.06, 2.0, 0.3}, kRule).place, PickPlace::kStale);
  EXPECT_EQ(pick_motion(at, {1.0, 2.0, 0.36}, kRule).place, PickPlace::kStale);
  EXPECT_EQ(pick_motion(at, {1.0, 2.0, 0.3 - 0.06}, kRule).place, PickPlace::kStale);
  // A whole turn back to the same heading is no turn (core::turn_rad wraps), as for the daemon.
  EXPECT_EQ(pick_motion(at, {1.0, 2.0, 0.3 + 2 * std::numbers::pi}, kRule).place, PickPlace::kHere);
  // Without the daemon's thresholds any motion is too far.
  EXPECT_EQ(pick_motion(at, {1.01, 2.0, 0.3}, StaleRule{}).place, PickPlace::kStale);
}

TEST(PickMotion, SaysHowFarTheBaseMoved) {
  const auto m = pick_motion({0, 0, 0}, {0.07, 0, 1.3 * std::numbers::pi / 180}, kRule);
  EXPECT_NEAR(m.travel_m, 0.07, 1e-12);
  EXPECT_EQ(moved_text(m), "the base moved 0.070 m / 1.3\u00b0 since");
}

TEST(CameraPointNow, IsThePointSeenFromTheNewPose) {
  const auto cb = forward_camera();
  const core::Vec3 c(0.1, -0.2, 1.5);  // 1.5 m ahead, 0.1 m right, 0.2 m up
  EXPECT_TRUE(camera_point_now(c, {0, 0, 0}, {0, 0, 0}, cb).isApprox(c, 1e-12));
  // Forward 0.4 m: the same point is 0.4 m nearer.
  EXPECT_TRUE(
      camera_point_now(c, {0, 0, 0}, {0.4, 0, 0}, cb).isApprox(core::Vec3(0.1, -0.2, 1.1), 1e-12));
  // Against the world: the point's world position is fixed whatever the poses.
  const core::PlanarPose a{0.3, -0.1, 0.2};
  const core::PlanarPose b{0.5, 0.05, -0.15};
  const auto world = [&](const core::Vec3& cam, const core::PlanarPose& p) {
    const core::Vec3 base = cb.to_base(cam);
    return core::Vec3(p.x_m + std::cos(p.yaw_rad) * base.x() - std::sin(p.yaw_rad) * base.y(),
                      p.y_m + std::sin(p.yaw_rad) * base.x() + std::cos(p.yaw_rad) * base.y(),
                      base.z());
  };
  EXPECT_TRUE(world(camera_point_now(c, a, b, cb), b).isApprox(world(c, a), 1e-12));
}

TEST(Guidance, ALandmarkLeavesTheImageAtTheStandoffThePinholeModelSays) {
  const Camera cam{core::PinholeIntrinsics{}, forward_camera(), 0.45, 4.5, 8};
  // 0.3 m to the left (base +y), on the door 1.0 m ahead: it leaves the image at the left when
  // 0.3 fx / z > cx - margin, i.e. below z = 0.3 * 570.3 / 311.5 = 0.549 m.
  const std::vector<Landmark> l{{"hinge edge (P1)", {1.0, 0.3, 0.0}}};
  EXPECT_EQ(out_of_view(cam, l[0].base_m, 0), "");
  EXPECT_EQ(out_of_view(cam, l[0].base_m, 0.5), "leaves the image at the left");
  const auto v = view_limits(cam, l, 1.0, 0.4);
  ASSERT_EQ(v.size(), 1U);
  EXPECT_NEAR(v[0].min_standoff_m, 0.5493, 0.0051);
  EXPECT_EQ(v[0].why, "leaves the image at the left");
  // The default keeps it in view (0.75 m when that does), rounded up to 5 cm, never past the door
  // distance.
  EXPECT_DOUBLE_EQ(default_standoff(v, 0.4, 0.75, 1.0), 0.75);
  EXPECT_DOUBLE_EQ(default_standoff(v, 0.4, 0.5, 1.0), 0.55);
  const std::vector<Landmark> high{{"handle free end", {1.0, 0.0, 0.35}}};
  const auto vh = view_limits(cam, high, 1.0, 0.4);
  EXPECT_EQ(vh[0].why, "leaves the image at the top");  // 0.35 * 570.3 / 231.5 = 0.862 m
  EXPECT_DOUBLE_EQ(default_standoff(vh, 0.4, 0.75, 1.0), 0.9);
  EXPECT_DOUBLE_EQ(default_standoff(vh, 0.4, 0.75, 0.8), 0.8);
  // Too near for the sensor's depth.
  EXPECT_EQ(out_of_view(cam, {0.5, 0, 0}, 0.1), "closer than the camera's 0.45 m minimum depth");
  EXPECT_EQ(out_of_view(cam, {0.5, 0, 0}, 0.6), "behind the camera");
  // Out of view already: no standoff keeps it.
  const auto gone = view_limits(cam, {{"x", {1.0, 2.0, 0}}}, 1.0, 0.4);
  EXPECT_FALSE(std::isfinite(gone[0].min_standoff_m));
}

TEST(Guidance, TheHandleSitsNextToTheMovingEdge) {
  const core::Vec3 hinge(1.0, 0.35, -0.2);
  const core::Vec3 moving(1.0, -0.40, -0.2);
  const core::Vec3 axis(1.0, -0.33, 0.1);  // 0.07 m from the moving edge
  EXPECT_EQ(hinge_side_problem(hinge, moving, axis), "");
  const auto problem = hinge_side_problem(moving, hinge, axis);  // P1 and P2 reversed
  EXPECT_NE(problem.find("P1 and P2 look reversed"), std::string::npos) << problem;
  EXPECT_NE(problem.find("0.07 m from P1"), std::string::npos) << problem;
  EXPECT_NEAR(along_edges(hinge, moving, axis), 0.68 / 0.75, 1e-12);
}

TEST(Guidance, PlaneFitAndDistances) {
  std::vector<core::Vec3> pts;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      pts.emplace_back(1.2, 0.1 * i, 0.1 * j);
  const auto plane = fit_points(pts);
  ASSERT_TRUE(plane);
  EXPECT_NEAR(std::abs(plane->normal.x()), 1.0, 1e-9);
  EXPECT_LT(plane->normal.x(), 0);  // toward the robot at the origin
  EXPECT_NEAR(plane->rms_residual_m, 0, 1e-12);
  EXPECT_NEAR(distance_to_plane(*plane, {1.25, 0.5, 0.5}), 0.05, 1e-12);
  EXPECT_FALSE(fit_points({{1, 0, 0}, {2, 0, 0}, {3, 0, 0}}));  // collinear
  EXPECT_FALSE(fit_points({{1, 0, 0}, {2, 0, 0}}));
}

}  // namespace
}  // namespace ajar::console
