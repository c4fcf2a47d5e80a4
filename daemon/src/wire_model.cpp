#include "ajar/daemon/wire_model.hpp"

namespace ajar::daemon {

protocol::RobotModel robot_model_of(const Config& config) {
  protocol::RobotModel r;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col)
      r.camera_to_base[static_cast<std::size_t>(row * 4 + col)] = config.camera_to_base_m(row, col);
  }
  const core::BaseGeometry& b = config.base;
  r.wheel_radius_m = b.wheel_radius_m;
  r.turning_radius_m = b.turning_radius_m;
  r.encoder_counts_per_rev = b.encoder_counts_per_rev;
  r.gear_ratio = b.gear_ratio;
  r.left = {static_cast<std::uint8_t>(b.left.card_axis), static_cast<std::int8_t>(b.left.polarity)};
  r.right = {static_cast<std::uint8_t>(b.right.card_axis),
             static_cast<std::int8_t>(b.right.polarity)};
  r.max_wheel_speed_rad_s = b.max_wheel_speed_rad_s;
  r.max_wheel_accel_rad_s2 = b.max_wheel_accel_rad_s2;
  const core::DriveLimits& d = config.drive;
  r.max_linear_speed_m_s = d.max_linear_speed_m_s;
  r.max_angular_speed_rad_s = d.max_angular_speed_rad_s;
  r.max_linear_accel_m_s2 = d.max_linear_accel_m_s2;
  r.max_angular_accel_rad_s2 = d.max_angular_accel_rad_s2;
  r.drive_command_timeout_s = d.command_timeout_s;
  r.approach_max_travel_m = d.approach_max_travel_m;
  r.approach_square_tolerance_rad = d.approach_square_tolerance_rad;
  r.approach_min_standoff_m = d.approach_min_standoff_m;
  r.stale_travel_m = d.stale_travel_m;
  r.stale_yaw_rad = d.stale_yaw_rad;
  const core::Limits& l = config.limits;
  r.arm_shoulder_m = l.arm.shoulder_m;
  r.arm_min_reach_m = l.arm.min_reach_m;
  r.arm_max_reach_m = l.arm.max_reach_m;
  r.arm_min_z_m = l.arm.min_z_m;
  r.arm_max_z_m = l.arm.max_z_m;
  r.min_depth_m = l.min_depth_m;
  r.max_depth_m = l.max_depth_m;
  r.min_door_width_m = l.min_door_width_m;
  r.max_door_width_m = l.max_door_width_m;
  r.min_handle_length_m = l.min_handle_length_m;
  r.max_handle_length_m = l.max_handle_length_m;
  r.max_yaw_correction_rad = l.max_yaw_correction_rad;
  r.aligned_tolerance_rad = config.control.aligned_tolerance_rad;
  r.min_point_separation_m = l.tolerances.min_point_separation_m;
  r.min_lateral_fraction = l.tolerances.min_lateral_fraction;
  r.collinearity = l.tolerances.collinearity;
  r.max_plane_rms_m = l.tolerances.max_plane_rms_m;
  r.max_door_tilt_rad = l.tolerances.max_door_tilt_rad;
  return r;
}

protocol::DriverKind wire_driver_kind(drivers::DriverKind kind) noexcept {
  switch (kind) {
    case drivers::DriverKind::kSim:
      return protocol::DriverKind::kSim;
    case drivers::DriverKind::kMock:
      return protocol::DriverKind::kMock;
    case drivers::DriverKind::kReal:
      return protocol::DriverKind::kReal;
  }
  return protocol::DriverKind::kReal;
}

}  // namespace ajar::daemon
