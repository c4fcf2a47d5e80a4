// The simulated world of `ajarctl simulate`: geometry without noise matches the scenario exactly
// (through core's own measurements), noise is seeded and bounded, and scenarios load strictly.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <stdlib.h>  // mkdtemp

#include <gtest/gtest.h>

#include "ajar/client/simulate.hpp"
#include "ajar/core/measurements.hpp"

namespace ajar::client {
namespace {

Scenario quiet(Scenario::Hinge hinge, double yaw_rad) {
  Scenario s;
  s.hinge = hinge;
  s.yaw_rad = yaw_rad;
  s.depth_noise_at_1m_m = 0;
  s.pixel_noise_px = 0;
  s.door_width_m = 0.9;
  s.distance_m = 1.0;
  s.lateral_offset_m = 0.3;
  return s;
}

core::CameraToBase paper_transform() {
  return core::CameraToBase::from_matrix(core::paper_camera_to_base_m()).value();
}

core::FramedPoint cam(const core::Vec3& p) {
  return core::FramedPoint{core::Frame::kCamera, p};
}

TEST(SimWorld, NoiselessPicksAreTheTruePointsInTheCameraFrame) {
  const Scenario s = quiet(Scenario::Hinge::kLeft, 0.2);
  SimWorld world(s, core::paper_camera_to_base_m());
  const auto t = paper_transform();
  for (double yaw : {0.0, 0.1, -0.3}) {
    const core::Vec3 p = world.moving_edge_point();
    const core::Vec3 picked = world.pick(p, yaw);
    EXPECT_TRUE(picked.isApprox(world.to_camera(p, yaw), 1e-12));
    // Back to the base frame, then into the world by the base's yaw.
    const core::Vec3 back = Eigen::AngleAxisd(yaw, core::Vec3::UnitZ()) * t.to_base(picked);
    EXPECT_TRUE(back.isApprox(p, 1e-9));
  }
}

TEST(SimWorld, DaemonMathOnNoiselessPicksRecoversTheDoor) {
  for (auto hinge : {Scenario::Hinge::kLeft, Scenario::Hinge::kRight}) {
    const Scenario s = quiet(hinge, 0.15);
    SimWorld world(s, core::paper_camera_to_base_m());
    const auto t = paper_transform();
    core::Limits limits;
    const auto width =
        core::measure_door_width(cam(world.pick(world.hinge_edge_point(), 0)),
                                 cam(world.pick(world.moving_edge_point(), 0)), t, limits);
    ASSERT_TRUE(width.ok()) << width.error().message;
    EXPECT_NEAR(width->span.length_m, 0.9, 1e-9);
    EXPECT_EQ(width->span.direction, hinge == Scenario::Hinge::kLeft
                                         ? core::RotationDirection::kCounterClockwise
                                         : core::RotationDirection::kClockwise);
    EXPECT_EQ(world.expected_ccw(), hinge == Scenario::Hinge::kLeft);
    const auto handle =
        core::measure_handle(cam(world.pick(world.handle_axis_point(), 0)),
                             cam(world.pick(world.handle_free_end_point(), 0)), t, limits);
    ASSERT_TRUE(handle.ok()) << handle.error().message;
    EXPECT_NEAR(handle->span.length_m, s.handle_length_m, 1e-9);
    for (int n : {3, 7, 16}) {
      std::vector<core::FramedPoint> points;
      for (const auto& p : world.plane_points(n))
        points.push_back(cam(world.pick(p, 0)));
      const auto plane = core::measure_door_plane(points, t, limits, core::BaseGeometry{});
      ASSERT_TRUE(plane.ok()) << plane.error().message;
      EXPECT_NEAR(plane->yaw_deviation_rad, 0.15, 1e-9) << n << " points";
    }
  }
}

TEST(SimWorld, AfterTurningByTheYawTheDoorIsSquare) {
  const Scenario s = quiet(Scenario::Hinge::kLeft, -0.25);
  SimWorld world(s, core::paper_camera_to_base_m());
  const auto t = paper_transform();
  std::vector<core::FramedPoint> points;
  for (const auto& p : world.plane_points(5))
    points.push_back(cam(world.pick(p, -0.25)));
  const auto plane = core::measure_door_plane(points, t, core::Limits{}, core::BaseGeometry{});
  ASSERT_TRUE(plane.ok());
  EXPECT_NEAR(plane->yaw_deviation_rad, 0, 1e-9);
  EXPECT_DOUBLE_EQ(world.true_yaw_error_rad(-0.25), 0);
}

TEST(SimWorld, NoiseIsSeededAndGrowsWithDepth) {
  Scenario s = quiet(Scenario::Hinge::kLeft, 0);
  s.depth_noise_at_1m_m = 0.01;
  s.pixel_noise_px = 0;
  const auto spread = [&](double distance_m) {
    Scenario d = s;
    d.distance_m = distance_m;
    SimWorld world(d, core::paper_camera_to_base_m());
    const core::Vec3 p = world.moving_edge_point();
    const double truth = world.to_camera(p, 0).z();
    double sum_sq = 0;
    for (int i = 0; i < 400; ++i)
      sum_sq += std::pow(world.pick(p, 0).z() - truth, 2);
    return std::sqrt(sum_sq / 400);
  };
  EXPECT_GT(spread(2.5), 3 * spread(1.0));  // sigma ~ depth^2: (2.35/0.85)^2 ~ 7.6x
  SimWorld a(s, core::paper_camera_to_base_m()), b(s, core::paper_camera_to_base_m());
  EXPECT_EQ(a.pick(a.hinge_edge_point(), 0), b.pick(b.hinge_edge_point(), 0));
}

TEST(Scenarios, EveryShippedScenarioLoads) {
  int count = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(AJAR_SOURCE_DIR) + "/config/scenarios")) {
    if (entry.path().extension() != ".yaml") continue;
    const Scenario s = load_scenario(entry.path().string());
    EXPECT_EQ(s.name, entry.path().stem().string());
    EXPECT_GE(s.plane_points, 3);
    ++count;
  }
  EXPECT_GE(count, 6);
}

TEST(Scenarios, MistakesNameTheKey) {
  std::string pattern = (std::filesystem::temp_directory_path() / "ajar-scenario-XXXXXX").string();
  ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
  const std::filesystem::path dir = pattern;
  const auto write = [&](const std::string& text) {
    std::ofstream(dir / "s.yaml") << text;
    return (dir / "s.yaml").string();
  };
  const auto error_of = [&](const std::string& text) {
    try {
      load_scenario(write(text));
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("door: {hinge: left, widht_m: 1}").find("door.widht_m"), std::string::npos);
  EXPECT_NE(error_of("door: {hinge: up}").find("door.hinge"), std::string::npos);
  EXPECT_NE(error_of("door: {width_m: -1}").find("door.width_m"), std::string::npos);
  EXPECT_NE(error_of("sensor: {}").find("door"), std::string::npos);
  EXPECT_NE(error_of("door: {}\noperator: {plane_points: 17}").find("operator.plane_points"),
            std::string::npos);
  EXPECT_NE(error_of("door: {hinge: right, yaw_deg: -90}").find("door.yaw_deg"), std::string::npos);
  EXPECT_EQ(load_scenario(write("door: {hinge: right, yaw_deg: -9}")).hinge,
            Scenario::Hinge::kRight);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ajar::client
