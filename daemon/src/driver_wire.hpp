// Internal to the engine: the drivers' states as the wire reports them (Status, Telemetry).
#pragma once

#include "ajar/drivers/lifecycle.hpp"
#include "ajar/drivers/manipulator.hpp"
#include "ajar/protocol/messages.hpp"

namespace ajar::daemon::detail {

inline protocol::DriverState to_wire(drivers::LifecycleState s) {
  switch (s) {
    case drivers::LifecycleState::kUnconfigured:
      return protocol::DriverState::kUnconfigured;
    case drivers::LifecycleState::kInactive:
      return protocol::DriverState::kInactive;
    case drivers::LifecycleState::kActive:
      return protocol::DriverState::kActive;
    case drivers::LifecycleState::kFault:
      return protocol::DriverState::kFault;
  }
  return protocol::DriverState::kFault;
}

inline protocol::ArmState to_wire(drivers::ArmPhase p) {
  switch (p) {
    case drivers::ArmPhase::kDisconnected:
      return protocol::ArmState::kDisconnected;
    case drivers::ArmPhase::kIdle:
      return protocol::ArmState::kIdle;
    case drivers::ArmPhase::kBusy:
      return protocol::ArmState::kBusy;
    case drivers::ArmPhase::kDone:
      return protocol::ArmState::kDone;
    case drivers::ArmPhase::kFault:
      return protocol::ArmState::kFault;
  }
  return protocol::ArmState::kFault;
}

}  // namespace ajar::daemon::detail
