#include "ajar/drivers/card_checks.hpp"

#include <cmath>

namespace ajar::drivers::card {

Error axis_error(ErrorCode code, int axis, const std::string& what) {
  return make_error(code, "axis", "axis " + std::to_string(axis) + ": " + what);
}

namespace {

// One axis of a set: within 1..axis_count and not listed before (`seen` is the set's bitmask).
Status check_next_axis(int axis, int axis_count, unsigned long long& seen) {
  if (axis < 1 || axis > axis_count || axis > 64) {
    return axis_error(ErrorCode::kCardBadParameter, axis,
                      "outside 1.." + std::to_string(axis_count));
  }
  const unsigned long long bit = 1ULL << (axis - 1);
  if ((seen & bit) != 0) return axis_error(ErrorCode::kCardBadParameter, axis, "listed twice");
  seen |= bit;
  return Ok{};
}

}  // namespace

Status check_axes(std::span<const int> axes, int axis_count) {
  unsigned long long seen = 0;
  for (const int axis : axes) {
    if (auto s = check_next_axis(axis, axis_count, seen); !s) return s;
  }
  return Ok{};
}

Status check_move(std::span<const AxisMove> moves, const TrapezoidProfile& profile,
                  int axis_count) {
  if (moves.empty()) return make_error(ErrorCode::kCardBadParameter, "moves", "no axis to move");
  // No list is built: this runs in the control loop.
  unsigned long long seen = 0;
  for (const AxisMove& m : moves) {
    if (auto s = check_next_axis(m.axis, axis_count, seen); !s) return s;
  }
  const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(profile.velocity_counts_per_ms)) {
    return make_error(
        ErrorCode::kCardBadParameter, "velocity_counts_per_ms",
        "must be finite and > 0, got " + std::to_string(profile.velocity_counts_per_ms));
  }
  if (!positive(profile.acceleration_counts_per_ms2)) {
    return make_error(
        ErrorCode::kCardBadParameter, "acceleration_counts_per_ms2",
        "must be finite and > 0, got " + std::to_string(profile.acceleration_counts_per_ms2));
  }
  if (!positive(profile.deceleration_counts_per_ms2)) {
    return make_error(
        ErrorCode::kCardBadParameter, "deceleration_counts_per_ms2",
        "must be finite and > 0, got " + std::to_string(profile.deceleration_counts_per_ms2));
  }
  if (!std::isfinite(profile.smooth_time_ms) || profile.smooth_time_ms < 0 ||
      profile.smooth_time_ms > 50) {
    return make_error(ErrorCode::kCardBadParameter, "smooth_time_ms",
                      "must be within 0..50, got " + std::to_string(profile.smooth_time_ms));
  }
  return Ok{};
}

Status check_can_move(const AxisStatus& st, int axis, std::int64_t distance_counts) {
  if (st.alarm) return axis_error(ErrorCode::kAxisAlarm, axis, "drive alarm");
  if (st.following_error) return axis_error(ErrorCode::kFollowingError, axis, "following error");
  if ((distance_counts > 0 && st.positive_limit) || (distance_counts < 0 && st.negative_limit)) {
    return axis_error(ErrorCode::kLimitHit, axis, "limit switch active in the move direction");
  }
  if (st.emergency_stopped) {
    return axis_error(ErrorCode::kEmergencyStopped, axis,
                      "emergency stop latched: clear faults first");
  }
  if (!st.enabled) {
    return axis_error(ErrorCode::kDriverError, axis, "servo is off: enable the axis first");
  }
  return Ok{};
}

}  // namespace ajar::drivers::card
