// Helpers for the arm tests: waiting on conditions with generous deadlines (never asserting
// timing), and a serial driver wired to a fresh simulator.
#pragma once

#include <chrono>
#include <memory>
#include <thread>

#include "ajar/drivers/arm_simulator.hpp"
#include "ajar/drivers/serial_arm.hpp"

namespace ajar::drivers::test {

// Polls `condition` until it holds or `deadline` passes; true if it held. The deadline is only a
// guard against hanging: it is far longer than anything should take on a loaded machine.
template <typename Condition>
bool wait_for(Condition condition, std::chrono::milliseconds deadline = std::chrono::seconds(20)) {
  const auto until = std::chrono::steady_clock::now() + deadline;
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= until) return condition();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

inline bool wait_phase(const Manipulator& arm, ArmPhase phase,
                       std::chrono::milliseconds deadline = std::chrono::seconds(20)) {
  return wait_for([&] { return arm.status().phase == phase; }, deadline);
}

inline DoorTask sample_task() {
  DoorTask t;
  t.contact_base_m = core::Vec3(0.65, -0.12, 0.95);
  t.door_width_m = 0.9;
  t.handle_length_m = 0.12;
  t.door_direction = core::RotationDirection::kClockwise;
  t.handle_direction = core::RotationDirection::kCounterClockwise;
  return t;
}

// Timeouts generous enough for a loaded machine under TSan; retries plenty.
inline SerialArmSettings serial_settings(const std::string& device) {
  SerialArmSettings s;
  s.device = device;
  s.ack_timeout_ms = 150;
  s.retries = 5;
  s.reconnect_min_ms = 10;
  s.reconnect_max_ms = 200;
  return s;
}

// The simulator first, so that it outlives the driver.
struct SerialRig {
  explicit SerialRig(ArmSimulatorSettings sim_settings = {})
      : sim(std::make_unique<ArmControllerSimulator>(sim_settings)),
        arm(std::make_unique<SerialManipulator>(serial_settings(sim->device_path()))) {}
  SerialRig(ArmSimulatorSettings sim_settings, SerialArmSettings arm_settings)
      : sim(std::make_unique<ArmControllerSimulator>(sim_settings)) {
    arm_settings.device = sim->device_path();
    arm = std::make_unique<SerialManipulator>(arm_settings);
  }
  std::unique_ptr<ArmControllerSimulator> sim;
  std::unique_ptr<SerialManipulator> arm;
};

}  // namespace ajar::drivers::test
