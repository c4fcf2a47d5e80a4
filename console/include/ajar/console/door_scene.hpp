// The simulated camera: a ray-cast door scene seen from the RGBD camera at the base's pose.
//
// The scene is the one `ajarctl simulate` uses (client::Scenario, config/scenarios/*.yaml,
// docs/simulation.md), in the world frame = the base frame when ajard started: a wall in the door's
// plane, the door leaf (width x height from bottom_z_m), a cubic handle standing off the leaf on a
// stem, and the floor at the door's bottom. Sensor model (structured light, Xtion class):
//   - depth noise: Gaussian with sigma = depth_noise_at_1m_m * z^2;
//   - quantisation: depth rounded to 1 mm (the 16-bit millimetre stream);
//   - holes: outside [0.45, 4.5] m, nothing hit, and 40 % of the handle's front face (the
//     specular metal returns no pattern).
// Deterministic per (seed, frame sequence).
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "ajar/client/simulate.hpp"
#include "ajar/console/frame.hpp"

namespace ajar::console {

struct SensorModel {
  core::PinholeIntrinsics intrinsics;  // Xtion Pro Live class, 640x480
  double depth_noise_at_1m_m = 0.0015;
  double depth_step_m = 0.001;  // quantisation; 0: none
  double min_range_m = 0.45;
  double max_range_m = 4.5;
  double handle_hole_fraction = 0.4;  // of the handle's front face
};

// What the operator should click, as world points (from client::SimWorld, the simulator's truth).
struct Landmarks {
  core::Vec3 hinge_edge, moving_edge, handle_axis, handle_free_end, contact;
  core::Vec3 leaf_low_left, leaf_low_right, leaf_high_middle;  // a wide triangle on the leaf
};

class DoorScene {
 public:
  DoorScene(const client::Scenario& scenario, const SensorModel& sensor);

  const client::Scenario& scenario() const { return scenario_; }
  const SensorModel& sensor() const { return sensor_; }

  // The camera's pose in the world for a base pose and the camera -> base calibration.
  static Eigen::Isometry3d camera_in_world(const BasePose& pose,
                                           const Eigen::Isometry3d& camera_to_base);

  // Renders one frame. `noise` false: exact depths (no noise, no quantisation, no handle holes),
  // for tests. The sequence number seeds the noise.
  void render(const BasePose& pose, const Eigen::Isometry3d& camera_to_base, std::uint64_t sequence,
              bool noise, Frame& out) const;

  // The two halves of render(): the exact geometry (which pixels are the specular handle face in
  // `specular`), then the sensor's effects (noise, quantisation, range, handle holes) on a copy.
  struct Exact {
    Frame frame;
    std::vector<std::uint8_t> specular;
  };
  void render_exact(const BasePose& pose, const Eigen::Isometry3d& camera_to_base,
                    Exact& out) const;
  void add_sensor_effects(const Exact& exact, std::uint64_t sequence, Frame& out) const;

  Landmarks landmarks() const;

 private:
  client::Scenario scenario_;
  SensorModel sensor_;
};

// The simulated frame source: renders the scene at the pose it is given. The calibration can be
// replaced once the daemon's RobotModel arrives (thread-safe).
class SimulatedSource final : public FrameSource {
 public:
  SimulatedSource(const std::string& scenario_path, const client::Scenario& scenario,
                  const SensorModel& sensor, double rate_hz, const Eigen::Matrix4d& camera_to_base);
  std::string describe() const override;
  double rate_hz() const override { return rate_hz_; }
  bool next(const BasePose& pose, Frame& out, std::string& why) override;
  void set_camera_to_base(const Eigen::Matrix4d& camera_to_base);
  const DoorScene& scene() const { return scene_; }
  Eigen::Isometry3d camera_to_base() const;

 private:
  std::string path_;
  DoorScene scene_;
  double rate_hz_;
  mutable std::mutex mutex_;
  Eigen::Isometry3d camera_to_base_;
  std::uint64_t sequence_ = 0;
  DoorScene::Exact cache_;  // the exact render of cached_pose_ / cached_transform_
  bool cache_valid_ = false;
  BasePose cached_pose_;
  Eigen::Matrix4d cached_transform_ = Eigen::Matrix4d::Zero();
};

}  // namespace ajar::console
