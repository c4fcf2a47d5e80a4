// The mocks' clock (MockMotionCard, MockManipulator): a function returning monotonic nanoseconds.
// Empty = the steady clock. Tests inject a fake clock they advance by hand, so they assert
// behaviour at chosen instants and never wait on (or measure) wall-clock time.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <utility>

namespace ajar::drivers {

using MockClock = std::function<std::int64_t()>;

inline std::int64_t steady_now_ns() noexcept {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// `clock`, or the steady clock when it is empty.
inline MockClock or_steady_clock(MockClock clock) {
  return clock ? std::move(clock) : MockClock(&steady_now_ns);
}

}  // namespace ajar::drivers
