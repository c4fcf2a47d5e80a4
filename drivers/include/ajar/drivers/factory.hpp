// Builds the drivers the config selects (drivers.kind): real hardware, the simulators, or mocks.
#pragma once

#include <memory>
#include <stdexcept>

#include "ajar/core/robot_model.hpp"
#include "ajar/drivers/manipulator.hpp"
#include "ajar/drivers/motion_card.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers {

// Start-up failure of a driver, naming what failed (e.g. the vendor library path, a missing symbol,
// the serial device).
class DriverStartupError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ArmControllerSimulator;

struct DriverSet {
  // Whatever must outlive the drivers (e.g. the in-process arm-controller simulator behind the
  // pseudo-terminal in sim mode). Declared first so that it is destroyed after card and arm.
  std::shared_ptr<void> keepalive;
  std::unique_ptr<MotionCard> card;
  std::unique_ptr<Manipulator> arm;
  // kSim: the in-process arm controller behind the pseudo-terminal (owned by keepalive), so that a
  // test can inject its faults (arm_simulator.hpp); null otherwise.
  ArmControllerSimulator* arm_simulator = nullptr;
};

// kReal: GTS4 driver over settings.card.library_path + serial arm on settings.arm.device.
// kSim:  the same GTS4 driver over the card simulator library + the serial arm driver over a
//        pseudo-terminal to an in-process arm-controller simulator.
//        settings.card.library_path empty = the simulator built with this tree; simulated time
//        runs settings.sim_speedup times faster (card simulator and arm task duration).
// kMock: in-process doubles with settings.mock's fault menu (MockMotionCard's clock also runs
//        sim_speedup times faster).
// The drivers come back bare and unopened: the caller wraps them in the lifecycle (lifecycle.hpp;
// the card in ManagedMotionCard over base.left/right.card_axis) and brings them up through it.
// Throws DriverStartupError when something cannot be loaded (library path, missing symbol) or the
// settings are unusable (wheel axes outside 1..card.axis_count or equal, sim_speedup <= 0).
DriverSet make_drivers(const DriverSettings& settings, const core::BaseGeometry& base);

}  // namespace ajar::drivers
