#include "ajar/daemon/wire_model.hpp"

#include "ajar/protocol/robot_model.hpp"

namespace ajar::daemon {

protocol::RobotModel robot_model_of(const Config& config) {
  protocol::RobotModel r =
      protocol::robot_model_from(config.camera_to_base_m, config.base, config.limits);
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
  r.aligned_tolerance_rad = config.control.aligned_tolerance_rad;
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
