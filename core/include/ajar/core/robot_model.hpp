// The robot's calibration and the limits the daemon validates against. Pure data: the daemon's
// config loader fills these from YAML (config/ajard.yaml) and checks them; core only reads them.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "ajar/core/types.hpp"

namespace ajar::core {

// One driving wheel on the GTS4 card.
struct WheelAxis {
  int card_axis = 1;  // GTS axis number, counts from 1
  int polarity = 1;   // +1 or -1: sign that makes positive counts roll the wheel forward
};

// Differential base (paper, Fig. 7 and eq. 6-7).
struct BaseGeometry {
  double wheel_radius_m = 0.1;            // R_W
  double turning_radius_m = 0.3;          // R_B: distance from turning centre O to each wheel
  double encoder_counts_per_rev = 10000;  // motor encoder counts per motor revolution
  double gear_ratio = 50.0;               // motor revolutions per wheel revolution
  WheelAxis left{1, 1};
  WheelAxis right{2, -1};
  double max_wheel_speed_rad_s = 1.0;
  double max_wheel_accel_rad_s2 = 2.0;
};

// The arm's reachable workspace in the base frame: a spherical shell around the shoulder,
// clipped by a height band.
struct ArmWorkspace {
  Vec3 shoulder_m = Vec3(0.25, 0.0, 0.3);
  double min_reach_m = 0.15;
  double max_reach_m = 1.0;
  double min_z_m = -0.5;  // the base origin is above the floor: the camera sits at z = -0.22
  double max_z_m = 1.2;
};

// Thresholds for degenerate input. All lengths in metres, angles in radians.
struct Tolerances {
  double min_point_separation_m = 0.01;  // closer points count as duplicates
  double min_lateral_fraction = 0.5;     // |dy| / |P1P2| below this: not side by side
  double collinearity = 0.02;            // plane: normalised thickness of the in-plane spread
  double max_plane_rms_m = 0.02;         // plane fit residual above this is refused
  double max_door_tilt_rad = 0.35;       // door normal may tilt this far from horizontal
};

// Driving the base (jog and approach) and when stored measurements go stale (docs/procedure.md,
// "Driving and stale measurements").
struct DriveLimits {
  double max_linear_speed_m_s = 0.3;           // jog: body speed along +x
  double max_angular_speed_rad_s = 0.6;        // jog: body yaw rate
  double max_linear_accel_m_s2 = 0.5;          // jog: speeding up and slowing down
  double max_angular_accel_rad_s2 = 1.2;       //
  double command_timeout_s = 0.5;              // a Drive command is valid this long
  double approach_max_travel_m = 1.5;          // longest accepted Approach move
  double approach_square_tolerance_rad = 0.2;  // |yaw to the door| above this: not square
  double approach_min_standoff_m = 0.4;        // smallest accepted standoff; forward jogs stop here
  double stale_forward_speed_m_s = 0.05;       // forward jog speed while the door distance is stale
  double stale_travel_m = 0.05;  // base origin displacement after which plane/contact are stale
  double stale_yaw_rad = 0.05;   // base turn (other than AlignBase's own) after which they are
};

struct Limits {
  double min_door_width_m = 0.5;
  double max_door_width_m = 2.0;
  double min_handle_length_m = 0.05;
  double max_handle_length_m = 0.3;
  double min_depth_m = 0.4;  // sensor's usable depth range (camera z)
  double max_depth_m = 4.0;
  double max_yaw_correction_rad = 0.7;
  Tolerances tolerances;
  ArmWorkspace arm;
};

}  // namespace ajar::core
