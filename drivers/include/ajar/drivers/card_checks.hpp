// Checks every MotionCard implementation makes the same way (GtsMotionCard, MockMotionCard), so
// that they refuse the same input with the same error codes.
#pragma once

#include <span>
#include <string>

#include "ajar/drivers/motion_card.hpp"

namespace ajar::drivers::card {

// An error about one axis: field "axis", message "axis N: what".
Error axis_error(ErrorCode code, int axis, const std::string& what);

// Axes within 1..axis_count, none twice; else kCardBadParameter.
Status check_axes(std::span<const int> axes, int axis_count);

// moves non-empty with valid, distinct axes; velocity, acceleration and deceleration finite and
// > 0; smooth time within 0..50 ms. Else kCardBadParameter naming the field.
Status check_move(std::span<const AxisMove> moves, const TrapezoidProfile& profile, int axis_count);

// Whether an axis in this state may start a move of `distance_counts`: kAxisAlarm,
// kFollowingError, kLimitHit (limit active in the direction of the move), kEmergencyStopped
// (latched until faults are cleared), kDriverError (servo off).
Status check_can_move(const AxisStatus& status, int axis, std::int64_t distance_counts);

}  // namespace ajar::drivers::card
