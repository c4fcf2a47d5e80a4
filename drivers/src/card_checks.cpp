#include "ajar/drivers/card_checks.hpp"

#include <cmath>

namespace ajar::drivers::card {

namespace {

// One axis of a set: within 1..axis_count and not listed before (`seen` is the set's bitmask).
ErrorCode check_next_axis(int axis, int axis_count, unsigned long long& seen, const char* call,
                          CardFailure& failure) noexcept {
  if (axis < 1 || axis > axis_count || axis > 64) {
    return fail(failure, ErrorCode::kCardBadParameter, call, axis,
                "axis outside 1..axis_count of the card");
  }
  const unsigned long long bit = 1ULL << (axis - 1);
  if ((seen & bit) != 0) {
    return fail(failure, ErrorCode::kCardBadParameter, call, axis, "axis listed twice");
  }
  seen |= bit;
  return ErrorCode::kOk;
}

bool positive(double v) noexcept {
  return std::isfinite(v) && v > 0;
}

}  // namespace

ErrorCode check_axes(std::span<const int> axes, int axis_count, const char* call,
                     CardFailure& failure) noexcept {
  unsigned long long seen = 0;
  for (const int axis : axes) {
    if (const auto e = check_next_axis(axis, axis_count, seen, call, failure);
        e != ErrorCode::kOk) {
      return e;
    }
  }
  return ErrorCode::kOk;
}

ErrorCode check_move(std::span<const AxisMove> moves, const TrapezoidProfile& profile,
                     int axis_count, CardFailure& failure) noexcept {
  constexpr const char* kCall = "move_relative";
  if (moves.empty())
    return fail(failure, ErrorCode::kCardBadParameter, kCall, 0, "no axis to move");
  unsigned long long seen = 0;
  for (const AxisMove& m : moves) {
    if (const auto e = check_next_axis(m.axis, axis_count, seen, kCall, failure);
        e != ErrorCode::kOk) {
      return e;
    }
  }
  if (!positive(profile.velocity_counts_per_ms)) {
    return fail(failure, ErrorCode::kCardBadParameter, kCall, 0,
                "velocity_counts_per_ms must be finite and > 0");
  }
  if (!positive(profile.acceleration_counts_per_ms2)) {
    return fail(failure, ErrorCode::kCardBadParameter, kCall, 0,
                "acceleration_counts_per_ms2 must be finite and > 0");
  }
  if (!positive(profile.deceleration_counts_per_ms2)) {
    return fail(failure, ErrorCode::kCardBadParameter, kCall, 0,
                "deceleration_counts_per_ms2 must be finite and > 0");
  }
  if (!std::isfinite(profile.smooth_time_ms) || profile.smooth_time_ms < 0 ||
      profile.smooth_time_ms > 50) {
    return fail(failure, ErrorCode::kCardBadParameter, kCall, 0,
                "smooth_time_ms must be within 0..50");
  }
  return ErrorCode::kOk;
}

ErrorCode check_can_move(const AxisStatus& st, int axis, std::int64_t direction, const char* call,
                         CardFailure& failure) noexcept {
  if (st.alarm) return fail(failure, ErrorCode::kAxisAlarm, call, axis, "drive alarm");
  if (st.following_error) {
    return fail(failure, ErrorCode::kFollowingError, call, axis, "following error");
  }
  if ((direction > 0 && st.positive_limit) || (direction < 0 && st.negative_limit)) {
    return fail(failure, ErrorCode::kLimitHit, call, axis,
                "limit switch active in the direction of motion");
  }
  if (st.emergency_stopped) {
    return fail(failure, ErrorCode::kEmergencyStopped, call, axis,
                "emergency stop latched: clear faults first");
  }
  if (!st.enabled) {
    return fail(failure, ErrorCode::kDriverError, call, axis,
                "servo is off: enable the axis first");
  }
  return ErrorCode::kOk;
}

}  // namespace ajar::drivers::card
