// ajarctl simulate: a closed-loop rehearsal of the whole door procedure against ajard on simulated
// hardware. The scenario (config/scenarios/*.yaml, docs/simulation.md) places a door in the world;
// the simulated operator picks points in the CAMERA frame, with sensor noise, from where the base
// truly is. A scenario with a `drive` section runs the whole of Fig. 4 from afar: jog toward the
// door, Approach to the width standoff, measure the width, Approach to the handle standoff, measure
// the handle, then plane, align, contact, engage.
//
// World frame: the base frame at the start of the run. The true base pose is the daemon's odometry
// relative to where the run started, unless the scenario models wheel slip or encoder noise: then
// it is integrated from the encoder deltas of every telemetry sample with the slip and the noise
// applied (so the daemon's odometry and the truth drift apart, as on a real floor).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "ajar/core/driving.hpp"
#include "ajar/core/types.hpp"

namespace ajar::client {

struct Command;
struct GlobalOptions;

struct Scenario {
  std::string name;
  std::string description;
  // Door (world frame = base frame at the start).
  enum class Hinge { kLeft, kRight } hinge = Hinge::kLeft;  // as the robot sees the door
  double door_width_m = 0.9;
  double door_height_m = 2.0;     // the door leaf's extent upward from door_bottom_z_m
  double door_bottom_z_m = -0.6;  // base-frame z of the floor line of the door
  double distance_m = 1.0;        // turning centre -> door plane, along the door normal
  double yaw_rad = 0.1;           // CCW turn that squares the robot up (door normal direction)
  double lateral_offset_m = 0;    // door centre left (+) of the foot of the normal
  double handle_axis_from_edge_m = 0.07;  // handle axis, measured in from the moving edge
  double handle_length_m = 0.12;
  double handle_height_m = 0.3;      // base-frame z of the handle
  double handle_offset_m = 0.06;     // handle stands this far proud of the door, toward the robot
  double width_pick_height_m = 0.3;  // base-frame z where the operator picks the door edges
  // Sensor (camera frame): depth noise sigma = depth_noise_at_1m_m * depth^2; pixel-picking error
  // sigma in pixels; focal length (pixels) to turn pixels into rays.
  double depth_noise_at_1m_m = 0.0015;
  double pixel_noise_px = 1.0;
  double focal_length_px = 570.0;
  double edge_inset_m = 0.0;  // operator picks this far inside each door edge
  // Run.
  std::uint64_t seed = 1;
  int plane_points = 3;
  int max_align_iterations = 3;  // align, re-measure, until the daemon says aligned
  // Tolerances (a run fails when one is missed).
  double width_tolerance_m = 0.02;
  double handle_tolerance_m = 0.02;
  double residual_yaw_tolerance_rad = 0.02;  // true yaw left after alignment
  double contact_tolerance_m = 0.03;
  bool expect_engaged = true;
  // Driving (Fig. 4 from afar); off unless the scenario has a `drive` section.
  bool drive = false;
  double jog_m = 0;                    // teleop forward this far first (Drive, re-sent while held)
  double jog_speed_m_s = 0.2;          //
  double width_standoff_m = 1.0;       // Approach here, then measure the width
  double handle_standoff_m = 0.75;     // Approach here, then measure the handle
  double wheel_slip = 0;               // fraction of each wheel's travel the floor does not follow
  double encoder_noise_rad = 0;        // per wheel and telemetry sample (random walk of the truth)
  double standoff_tolerance_m = 0.05;  // true final standoff vs handle_standoff_m
};

// Loads a scenario; throws std::runtime_error naming the file and key on a mistake (unknown keys
// included).
Scenario load_scenario(const std::string& path);

// The simulated world and sensor: pure geometry plus the noise model (deterministic per seed).
class SimWorld {
 public:
  SimWorld(const Scenario& scenario, const Eigen::Matrix4d& camera_to_base_m);

  // True points in the world frame.
  core::Vec3 hinge_edge_point() const;
  core::Vec3 moving_edge_point() const;
  core::Vec3 handle_axis_point() const;
  core::Vec3 handle_free_end_point() const;
  core::Vec3 contact_point() const;  // on the handle, two thirds of the way to the free end
  // `count` points on the door leaf, spread so that they are never collinear (deterministic layout
  // plus random jitter).
  std::vector<core::Vec3> plane_points(int count);
  core::Vec3 door_normal() const;  // unit, world frame, pointing from the door toward the robot

  // What the operator's pick of `world_point` gives in the camera frame when the base has turned
  // by `base_yaw_rad` in the world: pixel error moves the ray, the ray is re-intersected with the
  // surface the point lies on (the plane through the point parallel to the door), then depth noise
  // scales the point along its ray.
  core::Vec3 pick(const core::Vec3& world_point, double base_yaw_rad);
  core::Vec3 pick(const core::Vec3& world_point, const core::PlanarPose& base);
  // Without noise (for tests).
  core::Vec3 to_camera(const core::Vec3& world_point, double base_yaw_rad) const;
  core::Vec3 to_camera(const core::Vec3& world_point, const core::PlanarPose& base) const;
  // Perpendicular distance from the base origin at `base` to the door plane.
  double true_distance_m(const core::PlanarPose& base) const;

  // The true yaw the base still has to turn when it has turned by `base_yaw_rad`.
  double true_yaw_error_rad(double base_yaw_rad) const { return scenario_.yaw_rad - base_yaw_rad; }
  bool expected_ccw() const { return scenario_.hinge == Scenario::Hinge::kLeft; }

 private:
  core::Vec3 door_point(double lateral_m, double z_m, double proud_m = 0) const;
  Scenario scenario_;
  Eigen::Isometry3d camera_to_base_;
  std::mt19937_64 rng_;
};

// ajarctl simulate SCENARIO.yaml [--trace FILE] [--seeds N] [--seed S] [--plane-points N]
//                  [--config AJARD.yaml]
// --seeds N runs seeds S..S+N-1 and prints a summary (residual yaw statistics).
int run_simulate(const Command& command, const GlobalOptions& options, std::ostream& out,
                 std::ostream& err);

}  // namespace ajar::client
