#include "ajar/protocol/robot_model.hpp"

namespace ajar::protocol {

RobotModel robot_model_from(const Eigen::Matrix4d& camera_to_base_m, const core::BaseGeometry& base,
                            const core::Limits& limits, const core::DriveLimits& drive) noexcept {
  RobotModel r;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col)
      r.camera_to_base[static_cast<std::size_t>(row * 4 + col)] = camera_to_base_m(row, col);
  }
  r.wheel_radius_m = base.wheel_radius_m;
  r.turning_radius_m = base.turning_radius_m;
  r.encoder_counts_per_rev = base.encoder_counts_per_rev;
  r.gear_ratio = base.gear_ratio;
  const auto wheel = [](const core::WheelAxis& w) {
    return WheelModel{static_cast<std::uint8_t>(w.card_axis), static_cast<std::int8_t>(w.polarity)};
  };
  r.left = wheel(base.left);
  r.right = wheel(base.right);
  r.max_wheel_speed_rad_s = base.max_wheel_speed_rad_s;
  r.max_wheel_accel_rad_s2 = base.max_wheel_accel_rad_s2;
  r.max_linear_speed_m_s = drive.max_linear_speed_m_s;
  r.max_angular_speed_rad_s = drive.max_angular_speed_rad_s;
  r.max_linear_accel_m_s2 = drive.max_linear_accel_m_s2;
  r.max_angular_accel_rad_s2 = drive.max_angular_accel_rad_s2;
  r.drive_command_timeout_s = drive.command_timeout_s;
  r.approach_max_travel_m = drive.approach_max_travel_m;
  r.approach_square_tolerance_rad = drive.approach_square_tolerance_rad;
  r.approach_min_standoff_m = drive.approach_min_standoff_m;
  r.stale_travel_m = drive.stale_travel_m;
  r.stale_yaw_rad = drive.stale_yaw_rad;
  r.arm_shoulder_m = limits.arm.shoulder_m;
  r.arm_min_reach_m = limits.arm.min_reach_m;
  r.arm_max_reach_m = limits.arm.max_reach_m;
  r.arm_min_z_m = limits.arm.min_z_m;
  r.arm_max_z_m = limits.arm.max_z_m;
  r.min_depth_m = limits.min_depth_m;
  r.max_depth_m = limits.max_depth_m;
  r.min_door_width_m = limits.min_door_width_m;
  r.max_door_width_m = limits.max_door_width_m;
  r.min_handle_length_m = limits.min_handle_length_m;
  r.max_handle_length_m = limits.max_handle_length_m;
  r.max_yaw_correction_rad = limits.max_yaw_correction_rad;
  r.min_point_separation_m = limits.tolerances.min_point_separation_m;
  r.min_lateral_fraction = limits.tolerances.min_lateral_fraction;
  r.collinearity = limits.tolerances.collinearity;
  r.max_plane_rms_m = limits.tolerances.max_plane_rms_m;
  r.max_door_tilt_rad = limits.tolerances.max_door_tilt_rad;
  return r;
}

}  // namespace ajar::protocol
