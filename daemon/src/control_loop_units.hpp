// Internal to the control loop's sources: seconds to the loop's nanosecond clock.
#pragma once

#include <cmath>
#include <cstdint>

namespace ajar::daemon {

inline constexpr double kNsPerS = 1e9;

inline std::int64_t seconds_to_ns(double s) noexcept {
  return std::llround(s * kNsPerS);
}

}  // namespace ajar::daemon
