// The daemon's configuration as the wire protocol reports it (protocol 1.1): the RobotModel reply
// to GetRobotModel and Welcome.driver_kind. One place maps config to wire, field by field.
#pragma once

#include "ajar/daemon/config.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::daemon {

// Every calibration value and limit of `config` that a client needs to reproduce the daemon's
// derived values (docs/protocol.md, RobotModel). Values the daemon does not have yet are 0.
protocol::RobotModel robot_model_of(const Config& config);

protocol::DriverKind wire_driver_kind(drivers::DriverKind kind) noexcept;

}  // namespace ajar::daemon
