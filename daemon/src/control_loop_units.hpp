// Internal to the control loop's sources: seconds to the loop's nanosecond clock; the wheel-speed
// cap on a body velocity.
#pragma once

#include <cmath>
#include <cstdint>

#include "ajar/core/driving.hpp"

namespace ajar::daemon {

inline constexpr double kNsPerS = 1e9;

inline std::int64_t seconds_to_ns(double s) noexcept {
  return std::llround(s * kNsPerS);
}

// A body velocity within the wheel-speed cap: itself unless a wheel would turn faster than
// base.max_wheel_speed_rad_s; then both wheels are scaled (core::wheel_velocity) and this is the
// body velocity of the scaled wheels. What a jog's wheels are told (Telemetry's commanded_*).
inline core::BodyVelocity within_wheel_cap(core::BodyVelocity v,
                                           const core::BaseGeometry& base) noexcept {
  const double fastest_rad_s =
      (std::abs(v.linear_m_s) + std::abs(v.angular_rad_s) * base.turning_radius_m) /
      base.wheel_radius_m;
  if (!(fastest_rad_s > base.max_wheel_speed_rad_s)) return v;
  return core::body_velocity(core::wheel_velocity(v, base), base);
}

}  // namespace ajar::daemon
