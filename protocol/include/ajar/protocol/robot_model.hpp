// RobotModel (the reply to GetRobotModel, 1.1) from core's description of the robot: one builder
// for the daemon (from its configuration) and for the golden vectors (from the sample robot).
#pragma once

#include <Eigen/Core>

#include "ajar/core/robot_model.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::protocol {

// Fills what core describes: camera_to_base (the top three rows of the 4x4 ^B_C T, row-major),
// the base geometry and wheels, the wheel limits, the Drive, Approach and staleness limits, the
// arm workspace and the validation limits. aligned_tolerance_rad is the control loop's, not
// core's: it stays 0 for the caller to fill.
RobotModel robot_model_from(const Eigen::Matrix4d& camera_to_base_m, const core::BaseGeometry& base,
                            const core::Limits& limits, const core::DriveLimits& drive) noexcept;

}  // namespace ajar::protocol
