// The one fake clock of the tests: monotonic nanoseconds the test advances by hand. The mocks
// (mock_clock.hpp: MockMotionCard, MockManipulator), the engine (EngineOptions::now_ns) and the
// control loop driven cycle by cycle read it, so that a test asserts what happens at chosen
// instants and never how long anything took in real time (and a seed replays exactly). Declare it
// before whatever reads it (they call it until they are destroyed). Thread-safe (an atomic).
#pragma once

#include <atomic>
#include <cstdint>

#include "ajar/drivers/mock_clock.hpp"

namespace ajar::testing {

// One millisecond in the clock's nanoseconds.
inline constexpr std::int64_t kMs = 1'000'000;

class FakeClock {
 public:
  static constexpr std::int64_t kStartNs = 1'000'000'000;  // not 0: a clock rarely starts there

  std::int64_t now_ns() const { return now_ns_.load(); }
  // This clock as a function (MockClock, EngineOptions::now_ns).
  drivers::MockClock clock() const {
    return [this] { return now_ns_.load(); };
  }
  void advance_ns(std::int64_t ns) { now_ns_ += ns; }
  void advance_ms(double ms) { now_ns_ += static_cast<std::int64_t>(ms * 1e6); }

 private:
  std::atomic<std::int64_t> now_ns_{kStartNs};
};

}  // namespace ajar::testing
