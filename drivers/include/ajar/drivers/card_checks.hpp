// Checks every MotionCard implementation makes the same way (GtsMotionCard, MockMotionCard), so
// that they refuse the same input with the same error codes. Realtime-safe: noexcept, no
// allocation; a refusal fills `failure` (code, axis, a static reason) and returns its code.
#pragma once

#include <span>

#include "ajar/drivers/motion_card.hpp"

namespace ajar::drivers::card {

// Records a failure and returns its code.
inline ErrorCode fail(CardFailure& failure, ErrorCode code, const char* call, int axis,
                      const char* what, int vendor_code = 0) noexcept {
  failure = CardFailure{code, axis, vendor_code, call, what};
  return code;
}

// Axes within 1..axis_count, none twice; else kCardBadParameter.
ErrorCode check_axes(std::span<const int> axes, int axis_count, const char* call,
                     CardFailure& failure) noexcept;

// moves non-empty with valid, distinct axes; velocity, acceleration and deceleration finite and
// > 0; smooth time within 0..50 ms. Else kCardBadParameter naming the field.
ErrorCode check_move(std::span<const AxisMove> moves, const TrapezoidProfile& profile,
                     int axis_count, CardFailure& failure) noexcept;

// Whether an axis in this state may start a motion in `direction` (sign: > 0 positive, < 0
// negative, 0 none): kAxisAlarm, kFollowingError, kLimitHit (limit active in the direction of
// the motion), kEmergencyStopped (latched until faults are cleared), kDriverError (servo off).
ErrorCode check_can_move(const AxisStatus& status, int axis, std::int64_t direction,
                         const char* call, CardFailure& failure) noexcept;

}  // namespace ajar::drivers::card
