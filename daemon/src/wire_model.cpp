#include "ajar/daemon/wire_model.hpp"

#include "ajar/protocol/robot_model.hpp"

namespace ajar::daemon {

protocol::RobotModel robot_model_of(const Config& config) {
  protocol::RobotModel r =
      protocol::robot_model_from(config.camera_to_base_m, config.base, config.limits, config.drive);
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
