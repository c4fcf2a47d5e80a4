// Shared helpers for the motion-card tests: where the card simulator is, and a deadline-bounded
// wait (generous deadlines only: tests assert outcomes, never timing).
#pragma once

#include <array>
#include <chrono>
#include <optional>
#include <string>
#include <thread>

#include "ajar/drivers/motion_card.hpp"
#include "ajar/drivers/settings.hpp"

namespace ajar::drivers::testing {

// Simulated time runs this much faster than real time: moves of a few thousand counts finish in
// well under a millisecond of real time.
inline constexpr double kFastTimeScale = 1000.0;

// The two wheel axes of every card test (the card's axes 1 and 2).
inline constexpr std::array<int, 2> kWheels{1, 2};

inline std::string card_sim_path() {
  return AJAR_CARDSIM_PATH;
}

// libajar_gts_sim_nostop.so: the simulator without GT_Stop, built next to the simulator.
inline std::string card_sim_nostop_path() {
  const std::string sim = card_sim_path();
  return sim.substr(0, sim.find_last_of('/') + 1) + "libajar_gts_sim_nostop.so";
}

inline GtsCardSettings card_sim_settings() {
  GtsCardSettings s;
  s.library_path = card_sim_path();
  s.axis_count = 4;
  s.poll_timeout_ms = 10000;
  return s;
}

// axis_status() as a value: empty when the card refused (then last_failure() says why).
inline std::optional<AxisStatus> status_of(MotionCard& card, int axis) {
  AxisStatus st;
  if (card.axis_status(axis, st) != ErrorCode::kOk) return std::nullopt;
  return st;
}

// A realtime call's result with its text, for assertion messages.
inline std::string failure_text(const MotionCard& card) {
  return describe(card.last_failure());
}

// Polls `done` every millisecond until it holds or `timeout` passed; returns whether it held.
template <typename Pred>
bool wait_until(Pred&& done, std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

}  // namespace ajar::drivers::testing
