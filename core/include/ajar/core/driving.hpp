// Driving the base: body <-> wheel velocities, the jog speed limiter, dead-reckoning odometry, the
// straight approach move, and where the door is seen from the base after it moved. Pure math; the
// control loop and the procedure call it. docs/geometry.md ("Driving") has the equations.
//
// Frames: the odometry frame is the base frame at daemon start (+x forward, +y left, yaw CCW +).
// A PlanarPose is the base origin and heading in that frame. A base-frame measurement taken at pose
// A is seen from pose B by rebase(p, A, B).
#pragma once

#include "ajar/core/geometry.hpp"
#include "ajar/core/robot_model.hpp"
#include "ajar/core/types.hpp"

namespace ajar::core {

struct BodyVelocity {
  double linear_m_s = 0;     // along base +x, forward +
  double angular_rad_s = 0;  // yaw rate, CCW +
};

struct WheelVelocity {
  double left_rad_s = 0;  // wheel-forward positive
  double right_rad_s = 0;
};

struct PlanarPose {
  double x_m = 0, y_m = 0;
  double yaw_rad = 0;  // CCW +, not wrapped (odometry counts whole turns)
};

// Differential drive: left = (v - w R_B) / R_W, right = (v + w R_B) / R_W. When either wheel
// would exceed base.max_wheel_speed_rad_s both are scaled by the same factor (the path's curvature
// is kept). Non-finite input gives zero.
WheelVelocity wheel_velocity(BodyVelocity body, const BaseGeometry& base) noexcept;
// The inverse: v = R_W (l + r) / 2, w = R_W (r - l) / (2 R_B).
BodyVelocity body_velocity(WheelVelocity wheels, const BaseGeometry& base) noexcept;

// The jog speed limiter (as ros2_control's diff_drive SpeedLimiter): each component is clamped to
// its speed limit, then its change from `previous` to its acceleration limit times `dt_s`. A
// non-finite target counts as 0 (stop). `previous` is what was commanded one step earlier.
BodyVelocity limit_velocity(BodyVelocity target, BodyVelocity previous, double dt_s,
                            const DriveLimits& limits) noexcept;

// Dead reckoning: `pose` advanced by the wheels turning d_left_rad / d_right_rad (wheel-forward
// positive) along a constant-curvature arc (second-order: the heading at the arc's midpoint).
PlanarPose integrate_odometry(const PlanarPose& pose, double d_left_rad, double d_right_rad,
                              const BaseGeometry& base) noexcept;

// Straight-line distance between two poses' origins, and the turn between them (wrapped to
// (-pi, pi]).
double travel_m(const PlanarPose& from, const PlanarPose& to) noexcept;
double turn_rad(const PlanarPose& from, const PlanarPose& to) noexcept;

// A point measured in the base frame at pose `at`, expressed in the base frame at pose `now` (a
// rotation about z and a translation in the floor plane; z is unchanged).
Vec3 rebase(const Vec3& point_m, const PlanarPose& at, const PlanarPose& now) noexcept;

// Where the door is, seen from the base now.
struct DoorView {
  double distance_m = 0;  // base origin to the door plane, perpendicular (> 0: in front)
  double yaw_rad = 0;     // the turn that squares the base up to the door, CCW + (as eq. 5)
};
// From the door plane measured at pose `at` (normal toward the robot, centroid on the door).
DoorView door_from_plane(const Plane& plane, const PlanarPose& at, const PlanarPose& now) noexcept;
// Before a plane: from the width points (base frame at `at`). The door is taken as the vertical
// plane through their horizontal line: distance from the base origin to it, and the turn that
// faces it squarely. The points must be distinct in the floor plane (measure_span checked that).
DoorView door_from_width(const Vec3& p1_m, const Vec3& p2_m, const PlanarPose& at,
                         const PlanarPose& now) noexcept;

// The door as a line in the odometry frame (for a bound the control loop checks every cycle from
// its own odometry): the distance from a pose's origin to the door plane is
// door_distance_m(line, x, y) = normal_x * x + normal_y * y + offset_m, the same as
// DoorView::distance_m from that pose (the normal points toward where the robot was when the door
// was measured).
struct DoorLine {
  double normal_x_m = 0, normal_y_m = 0;  // unit horizontal normal, odometry frame
  double offset_m = 0;
  friend bool operator==(const DoorLine&, const DoorLine&) = default;
};
DoorLine door_line_from_plane(const Plane& plane, const PlanarPose& at) noexcept;
DoorLine door_line_from_width(const Vec3& p1_m, const Vec3& p2_m, const PlanarPose& at) noexcept;
inline double door_distance_m(const DoorLine& line, double x_m, double y_m) noexcept {
  return line.normal_x_m * x_m + line.normal_y_m * y_m + line.offset_m;
}

// Approach: both wheels the same way, theta = travel / R_W, in card counts with polarity (rounded
// half away from zero, like wheel_command). A non-finite travel, or one whose counts would exceed
// 2^53, gives zero counts.
struct StraightCommand {
  double wheel_rad = 0;  // each wheel, wheel-forward positive
  std::int64_t left_counts = 0;
  std::int64_t right_counts = 0;
};
StraightCommand straight_command(double travel_m, const BaseGeometry& base) noexcept;

}  // namespace ajar::core
