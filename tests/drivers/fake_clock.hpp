// A clock the test advances by hand, for the mocks' injectable clock (mock_clock.hpp): tests
// assert what the mock does at chosen instants, never how long anything took in real time.
// Declare it before the mock that uses it (the mock calls it until it is destroyed).
#pragma once

#include <atomic>
#include <cstdint>

#include "ajar/drivers/mock_clock.hpp"

namespace ajar::drivers::testing {

class FakeClock {
 public:
  MockClock clock() {
    return [this] { return now_ns_.load(); };
  }
  void advance_ms(double ms) { now_ns_ += static_cast<std::int64_t>(ms * 1e6); }
  void advance_ns(std::int64_t ns) { now_ns_ += ns; }

 private:
  std::atomic<std::int64_t> now_ns_{1'000'000'000};  // not 0: a clock rarely starts there
};

}  // namespace ajar::drivers::testing
