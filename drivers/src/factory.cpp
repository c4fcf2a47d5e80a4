#include "ajar/drivers/factory.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "ajar/drivers/arm_simulator.hpp"
#include "ajar/drivers/gts_card.hpp"
#include "ajar/drivers/gts_sim_control.hpp"
#include "ajar/drivers/mock_arm.hpp"
#include "ajar/drivers/mock_card.hpp"
#include "ajar/drivers/serial_arm.hpp"

namespace ajar::drivers {

namespace {

// Kept alive by DriverSet::keepalive in sim mode.
struct SimBackends {
  std::unique_ptr<GtsSimControl> card_sim;
  std::unique_ptr<ArmControllerSimulator> arm_sim;
};

void check_wheel_axes(const core::BaseGeometry& base, int axis_count) {
  for (const int axis : {base.left.card_axis, base.right.card_axis}) {
    if (axis < 1 || axis > axis_count) {
      throw DriverStartupError("wheel card axis " + std::to_string(axis) + " outside 1.." +
                               std::to_string(axis_count) + " (drivers.card.axis_count)");
    }
  }
  if (base.left.card_axis == base.right.card_axis) {
    throw DriverStartupError("left and right wheels share card axis " +
                             std::to_string(base.left.card_axis));
  }
}

}  // namespace

DriverSet make_drivers(const DriverSettings& settings, const core::BaseGeometry& base) {
  check_wheel_axes(base, settings.card.axis_count);
  if (!std::isfinite(settings.sim_speedup) || !(settings.sim_speedup > 0)) {
    throw DriverStartupError("drivers.sim_speedup must be > 0");
  }
  DriverSet set;
  std::unique_ptr<MotionCard> card;
  std::unique_ptr<Manipulator> arm;
  switch (settings.kind) {
    case DriverKind::kReal:
      card = std::make_unique<GtsMotionCard>(settings.card);
      arm = std::make_unique<SerialManipulator>(settings.arm);
      break;
    case DriverKind::kSim: {
      GtsCardSettings card_settings = settings.card;
      if (card_settings.library_path.empty()) {
        card_settings.library_path = default_card_simulator_path();
      }
      if (card_settings.library_path.empty()) {
        throw DriverStartupError("no card simulator library: set drivers.card.library_path");
      }
      auto backends = std::make_shared<SimBackends>();
      card = std::make_unique<GtsMotionCard>(card_settings);
      backends->card_sim = std::make_unique<GtsSimControl>(card_settings.library_path);
      backends->card_sim->set_time_scale(settings.sim_speedup);
      ArmSimulatorSettings arm_sim;
      arm_sim.task_duration_ms = std::max(
          1, static_cast<int>(std::lround(arm_sim.task_duration_ms / settings.sim_speedup)));
      try {
        backends->arm_sim = std::make_unique<ArmControllerSimulator>(arm_sim);
      } catch (const std::exception& e) {
        throw DriverStartupError(std::string("cannot start the arm-controller simulator: ") +
                                 e.what());
      }
      SerialArmSettings arm_settings = settings.arm;
      arm_settings.device = backends->arm_sim->device_path();
      arm = std::make_unique<SerialManipulator>(arm_settings);
      set.arm_simulator = backends->arm_sim.get();
      set.keepalive = std::move(backends);
      break;
    }
    case DriverKind::kMock:
      card = std::make_unique<MockMotionCard>(settings.mock.card_fault, settings.mock.slow_ms,
                                              settings.sim_speedup, settings.card.axis_count);
      arm = std::make_unique<MockManipulator>(settings.mock.arm_fault, settings.mock.slow_ms);
      break;
  }
  set.card = std::move(card);
  set.arm = std::move(arm);
  return set;
}

}  // namespace ajar::drivers
