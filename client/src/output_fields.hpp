// What the JSON and the text renderings of ajarctl's output share (client/src/output_*.cpp).
#pragma once

#include <string>
#include <string_view>

#include "ajar/protocol/messages.hpp"

namespace ajar::client::output {

inline std::string state_name(protocol::ProcedureState s) {
  return std::string(protocol::to_string(s));
}

// RobotModel's scalar fields under their wire names (docs/protocol.md 5.22): the JSON keys and the
// text lines both come from this table.
struct ModelField {
  std::string_view name;
  double protocol::RobotModel::*member;
};
inline constexpr ModelField kModelFields[] = {
    {"wheel_radius_m", &protocol::RobotModel::wheel_radius_m},
    {"turning_radius_m", &protocol::RobotModel::turning_radius_m},
    {"encoder_counts_per_rev", &protocol::RobotModel::encoder_counts_per_rev},
    {"gear_ratio", &protocol::RobotModel::gear_ratio},
    {"max_wheel_speed_rad_s", &protocol::RobotModel::max_wheel_speed_rad_s},
    {"max_wheel_accel_rad_s2", &protocol::RobotModel::max_wheel_accel_rad_s2},
    {"max_linear_speed_m_s", &protocol::RobotModel::max_linear_speed_m_s},
    {"max_angular_speed_rad_s", &protocol::RobotModel::max_angular_speed_rad_s},
    {"max_linear_accel_m_s2", &protocol::RobotModel::max_linear_accel_m_s2},
    {"max_angular_accel_rad_s2", &protocol::RobotModel::max_angular_accel_rad_s2},
    {"drive_command_timeout_s", &protocol::RobotModel::drive_command_timeout_s},
    {"approach_max_travel_m", &protocol::RobotModel::approach_max_travel_m},
    {"approach_square_tolerance_rad", &protocol::RobotModel::approach_square_tolerance_rad},
    {"approach_min_standoff_m", &protocol::RobotModel::approach_min_standoff_m},
    {"stale_travel_m", &protocol::RobotModel::stale_travel_m},
    {"stale_yaw_rad", &protocol::RobotModel::stale_yaw_rad},
    {"arm_min_reach_m", &protocol::RobotModel::arm_min_reach_m},
    {"arm_max_reach_m", &protocol::RobotModel::arm_max_reach_m},
    {"arm_min_z_m", &protocol::RobotModel::arm_min_z_m},
    {"arm_max_z_m", &protocol::RobotModel::arm_max_z_m},
    {"min_depth_m", &protocol::RobotModel::min_depth_m},
    {"max_depth_m", &protocol::RobotModel::max_depth_m},
    {"min_door_width_m", &protocol::RobotModel::min_door_width_m},
    {"max_door_width_m", &protocol::RobotModel::max_door_width_m},
    {"min_handle_length_m", &protocol::RobotModel::min_handle_length_m},
    {"max_handle_length_m", &protocol::RobotModel::max_handle_length_m},
    {"max_yaw_correction_rad", &protocol::RobotModel::max_yaw_correction_rad},
    {"aligned_tolerance_rad", &protocol::RobotModel::aligned_tolerance_rad},
    {"min_point_separation_m", &protocol::RobotModel::min_point_separation_m},
    {"min_lateral_fraction", &protocol::RobotModel::min_lateral_fraction},
    {"collinearity", &protocol::RobotModel::collinearity},
    {"max_plane_rms_m", &protocol::RobotModel::max_plane_rms_m},
    {"max_door_tilt_rad", &protocol::RobotModel::max_door_tilt_rad},
};

}  // namespace ajar::client::output
