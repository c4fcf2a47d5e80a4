// The simulated camera: a known plane renders to known depths; the sensor model's noise grows
// with z^2, is quantised, and leaves holes on the handle; after turning by the door's yaw the
// door is seen square.
#include "ajar/console/door_scene.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "ajar/core/geometry.hpp"

namespace ajar::console {
namespace {

Eigen::Isometry3d paper() {
  Eigen::Isometry3d t;
  t.matrix() = core::paper_camera_to_base_m();
  return t;
}

client::Scenario wall_ahead(double distance_m) {
  client::Scenario s;
  s.yaw_rad = 0;
  s.distance_m = distance_m;
  s.door_width_m = 4.5;  // wider than the view: every non-floor pixel is the leaf
  s.door_height_m = 4.0;
  s.door_bottom_z_m = -0.6;
  s.handle_height_m = 2.9;  // above the view
  return s;
}

float depth_at(const Frame& f, int u, int v) {
  return f.depth_m[static_cast<std::size_t>(v * f.intrinsics.width_px + u)];
}

TEST(DoorScene, AWallAheadRendersToItsDistanceAndTheFloorToItsHeight) {
  SensorModel sensor;
  const DoorScene scene(wall_ahead(2.0), sensor);
  Frame f;
  scene.render({}, paper(), 1, false, f);
  const auto& k = f.intrinsics;
  ASSERT_EQ(f.depth_m.size(), 640U * 480U);
  // Camera z of the wall: 2.0 m minus the camera's 0.15 m forward offset (eq. 2).
  const double wall_z = 2.0 - 0.15;
  // The floor (base z = -0.6) is 0.38 m below the camera (base z = -0.22): camera y = +0.38.
  int wall = 0;
  int floor = 0;
  for (int v = 0; v < k.height_px; ++v) {
    for (int u = 0; u < k.width_px; u += 7) {
      const double z = depth_at(f, u, v);
      ASSERT_GT(z, 0) << u << "," << v;
      const double floor_z = v > k.cy_px ? 0.38 * k.fy_px / (v - k.cy_px) : 1e9;
      if (std::abs(z - wall_z) < 1e-6) {
        ++wall;
        EXPECT_LT(wall_z, floor_z + 1e-6);  // the wall is the nearer surface here
      } else {
        EXPECT_NEAR(z, floor_z, 1e-6) << u << "," << v;
        ++floor;
      }
    }
  }
  EXPECT_GT(wall, 1000);
  EXPECT_GT(floor, 1000);
}

TEST(DoorScene, LandmarksRenderWhereTheSimulatorPutsThem) {
  client::Scenario s;  // a door 1.5 m away, yaw 0.1 rad: both edges in view
  s.distance_m = 1.5;
  s.door_width_m = 0.8;
  s.handle_height_m = -0.1;
  s.width_pick_height_m = -0.3;
  SensorModel sensor;
  const DoorScene scene(s, sensor);
  for (const double yaw : {0.0, 0.1}) {
    const BasePose pose{0, 0, yaw};
    Frame f;
    scene.render(pose, paper(), 1, false, f);
    const auto cam = DoorScene::camera_in_world(pose, paper()).inverse();
    const auto l = scene.landmarks();
    for (const auto& p : {l.hinge_edge, l.moving_edge, l.handle_axis, l.handle_free_end, l.contact,
                          l.leaf_low_left, l.leaf_high_middle}) {
      const core::Vec3 c = cam * p;
      const auto px = core::project(f.intrinsics, c);
      ASSERT_TRUE(px.has_value());
      const auto pick = core::pick_point(f.intrinsics, f.depth(), px->u_px, px->v_px);
      ASSERT_TRUE(pick.ok()) << pick.error().message;
      EXPECT_NEAR(pick->depth_m, c.z(), 0.01) << "yaw " << yaw;
    }
  }
}

TEST(DoorScene, AfterTurningByTheDoorYawTheDoorIsSquare) {
  client::Scenario s;
  s.yaw_rad = 0.25;
  s.handle_height_m = 2.9;
  SensorModel sensor;
  const DoorScene scene(s, sensor);
  Frame before;
  Frame after;
  scene.render({0, 0, 0}, paper(), 1, false, before);
  scene.render({0, 0, s.yaw_rad}, paper(), 1, false, after);
  const int v = 200;  // above the floor, on the door
  // Square: the same depth on both sides of the image; before the turn the left side is nearer
  // (a door yawed CCW is closer on the robot's left).
  EXPECT_NEAR(depth_at(after, 220, v), depth_at(after, 420, v), 1e-6);
  EXPECT_LT(depth_at(before, 220, v) + 0.02F, depth_at(before, 420, v));
}

double noise_sigma(double camera_z_m) {
  const auto s = wall_ahead(camera_z_m + 0.15);
  SensorModel sensor;
  sensor.depth_noise_at_1m_m = 0.004;
  const DoorScene scene(s, sensor);
  Frame exact;
  Frame noisy;
  scene.render({}, paper(), 7, false, exact);
  scene.render({}, paper(), 7, true, noisy);
  double sum2 = 0;
  int n = 0;
  for (int v = 40; v < 200; ++v) {
    for (int u = 0; u < 640; ++u) {
      const auto i = static_cast<std::size_t>(v * 640 + u);
      const double d = noisy.depth_m[i];
      EXPECT_NEAR(std::round(d * 1000.0), d * 1000.0, 1e-3);  // quantised to 1 mm
      const double e = d - static_cast<double>(exact.depth_m[i]);
      sum2 += e * e;
      ++n;
    }
  }
  return std::sqrt(sum2 / n);
}

TEST(DoorScene, DepthNoiseGrowsWithTheSquareOfTheDepth) {
  const double near = noise_sigma(1.0);
  const double far = noise_sigma(2.0);
  // sigma = 4 mm at 1 m and 16 mm at 2 m, plus 1 mm quantisation (0.29 mm rms).
  EXPECT_NEAR(near, 0.004, 0.0006);
  EXPECT_NEAR(far, 0.016, 0.0015);
}

TEST(DoorScene, TheSpecularHandleHasHolesButAClickOnItStillFindsIt) {
  client::Scenario s;
  s.handle_height_m = -0.1;
  SensorModel sensor;
  const DoorScene scene(s, sensor);
  Frame f;
  scene.render({}, paper(), 3, true, f);
  const auto l = scene.landmarks();
  const auto cam = DoorScene::camera_in_world({}, paper()).inverse();
  const core::Vec3 c = cam * l.contact;
  const auto px = core::project(f.intrinsics, c);
  ASSERT_TRUE(px.has_value());
  int holes = 0;
  for (int dv = -3; dv <= 3; ++dv) {
    for (int du = -3; du <= 3; ++du) {
      holes += depth_at(f, static_cast<int>(std::lround(px->u_px)) + du,
                        static_cast<int>(std::lround(px->v_px)) + dv) == 0.0F;
    }
  }
  EXPECT_GT(holes, 10);
  EXPECT_LT(holes, 40);
  // A click anywhere near the contact point (on a hole or not) measures the handle, not the door
  // 6 cm behind it.
  for (int du = -3; du <= 3; ++du) {
    const auto pick = core::pick_point(f.intrinsics, f.depth(), px->u_px + du, px->v_px);
    ASSERT_TRUE(pick.ok()) << pick.error().message;
    EXPECT_NEAR(pick->depth_m, c.z(), 0.012);
  }
}

}  // namespace
}  // namespace ajar::console
