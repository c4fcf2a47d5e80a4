// MockMotionCard's MotionCard calls (mock_card.hpp); the model and the test configuration are in
// mock_card.cpp.
#include <cmath>
#include <limits>

#include "ajar/drivers/card_checks.hpp"
#include "ajar/drivers/mock_card.hpp"

namespace ajar::drivers {

using card::fail;

namespace {

// kConstantSpeed: a move at `speed` from the first instant, landing exactly on the goal.
profile::Motion constant_move(std::int64_t t0_ns, double from, double goal, double speed) {
  profile::Motion m;
  m.t0_ns = t0_ns;
  m.p0 = from;
  m.v0 = profile::sign(goal - from) * speed;
  m.add(std::fabs(goal - from) / speed, 0);
  m.exact_end = true;
  m.end = goal;
  return m;
}

// kConstantSpeed: a jog holds `velocity` from the first instant (0: rests at once).
profile::Motion constant_jog(std::int64_t t0_ns, double from, double velocity) {
  profile::Motion m;
  m.t0_ns = t0_ns;
  m.p0 = from;
  m.v0 = velocity;
  if (velocity != 0) m.add(std::numeric_limits<double>::infinity(), 0);
  return m;
}

}  // namespace

#define AJAR_MOCK_TRY(expr) \
  if (const ErrorCode e_ = (expr); e_ != ErrorCode::kOk) return e_

Outcome MockMotionCard::open() {
  Lock lock;
  (void)enter(lock, CardCall::kOpen, "open", false);
  if (open_fails_) return make_error(ErrorCode::kCardOpenFailed, "", "mock card: no card");
  // Like GT_Open + GT_Reset + GT_ClrSts: axes off at position 0, no faults.
  open_ = true;
  for (Axis& a : axes_)
    a = Axis{};
  return Ok{};
}

Outcome MockMotionCard::close() {
  Lock lock;
  (void)enter(lock, CardCall::kClose, "close", false);
  open_ = false;
  return Ok{};
}

ErrorCode MockMotionCard::enable_axes(std::span<const int> axes) noexcept {
  return axes_call(CardCall::kEnableAxes, "enable_axes", axes, [&]() noexcept {
    AJAR_MOCK_TRY(check_axes(axes, "enable_axes"));
    for (const int n : axes) {  // all checked before any is switched on
      if (axis(n).alarm) {
        return fail(last_, ErrorCode::kAxisAlarm, "enable_axes", n,
                    "drive alarm latched: clear faults first");
      }
    }
    for (const int n : axes) {
      Axis& a = axis(n);
      if (enable_delay_reads_ > 0 && !a.enabled) {
        a.enable_pending = enable_delay_reads_;
      } else {
        a.enabled = true;
      }
    }
    return ErrorCode::kOk;
  });
}

ErrorCode MockMotionCard::disable_axes(std::span<const int> axes) noexcept {
  return axes_call(CardCall::kDisableAxes, "disable_axes", axes, [&]() noexcept {
    AJAR_MOCK_TRY(check_axes(axes, "disable_axes"));
    if (take_drop(CardCall::kDisableAxes)) return ErrorCode::kOk;  // accepted, not applied
    for (const int n : axes) {
      Axis& a = axis(n);
      halt(a);
      a.enabled = false;
      a.enable_pending = 0;
    }
    return ErrorCode::kOk;
  });
}

ErrorCode MockMotionCard::clear_faults(std::span<const int> axes) noexcept {
  return axes_call(CardCall::kClearFaults, "clear_faults", axes, [&]() noexcept {
    AJAR_MOCK_TRY(check_axes(axes, "clear_faults"));
    for (const int n : axes) {
      Axis& a = axis(n);
      if (!alarm_persists_) a.alarm = false;
      a.following_error = a.positive_limit = a.negative_limit = false;
      a.smooth_stopped = a.emergency_stopped = false;
    }
    return ErrorCode::kOk;
  });
}

ErrorCode MockMotionCard::move_relative(std::span<const AxisMove> moves,
                                        const TrapezoidProfile& profile) noexcept {
  Lock lock;
  AJAR_MOCK_TRY(enter(lock, CardCall::kMoveRelative, "move_relative", true));
  const auto result = [&]() noexcept {
    if (refuse_move_ != ErrorCode::kOk) {
      const ErrorCode code = refuse_move_;
      refuse_move_ = ErrorCode::kOk;
      return fail(last_, code, "move_relative", 0, "mock card: move refused (test)");
    }
    AJAR_MOCK_TRY(check_open("move_relative"));
    AJAR_MOCK_TRY(card::check_move(moves, profile, axis_count_, last_));
    for (const AxisMove& m : moves) {
      AJAR_MOCK_TRY(
          check_can_start(m.axis, static_cast<double>(m.distance_counts), false, "move_relative"));
    }
    if (take_drop(CardCall::kMoveRelative)) return ErrorCode::kOk;  // accepted, not applied
    const std::int64_t t0 = now_ns();
    for (const AxisMove& m : moves) {
      Axis& a = axis(m.axis);
      double velocity = 0;
      const double here = sample(a, &velocity);
      const double goal = std::round(here) + static_cast<double>(m.distance_counts);
      start(a, false, fault_ == MockFault::kStuck || stick_move_, goal >= here ? 1 : -1, here,
            profile.deceleration_counts_per_ms2,
            model_ == MockMotionModel::kConstantSpeed
                ? constant_move(t0, here, goal, profile.velocity_counts_per_ms)
                : profile::plan_trap(t0, here, velocity, goal, profile.velocity_counts_per_ms,
                                     profile.acceleration_counts_per_ms2,
                                     profile.deceleration_counts_per_ms2));
    }
    stick_move_ = false;
    return applied_result(CardCall::kMoveRelative, ErrorCode::kOk, "move_relative");
  }();
  if (!recording_) return result;
  CardCallRecord r = record(CardCall::kMoveRelative);
  r.moves.assign(moves.begin(), moves.end());
  r.profile = profile;
  return logged(std::move(r), result);
}

ErrorCode MockMotionCard::jog(std::span<const AxisVelocity> axes,
                              const JogProfile& profile) noexcept {
  Lock lock;
  AJAR_MOCK_TRY(enter(lock, CardCall::kJog, "jog", true));
  const auto result = [&]() noexcept {
    AJAR_MOCK_TRY(check_open("jog"));
    AJAR_MOCK_TRY(card::check_jog(axes, profile, axis_count_, last_));
    for (const AxisVelocity& v : axes) {
      AJAR_MOCK_TRY(check_can_start(v.axis, v.velocity_counts_per_ms, true, "jog"));
    }
    if (take_drop(CardCall::kJog)) return ErrorCode::kOk;  // accepted, not applied
    const std::int64_t t0 = now_ns();
    for (const AxisVelocity& v : axes) {
      Axis& a = axis(v.axis);
      double velocity = 0;
      const double here = sample(a, &velocity);
      start(a, true, fault_ == MockFault::kStuck && v.velocity_counts_per_ms != 0,
            v.velocity_counts_per_ms != 0 ? profile::sign(v.velocity_counts_per_ms)
                                          : profile::sign(velocity),
            here, profile.deceleration_counts_per_ms2,
            model_ == MockMotionModel::kConstantSpeed
                ? constant_jog(t0, here, v.velocity_counts_per_ms)
                : profile::plan_jog(t0, here, velocity, v.velocity_counts_per_ms,
                                    profile.acceleration_counts_per_ms2,
                                    profile.deceleration_counts_per_ms2));
    }
    return applied_result(CardCall::kJog, ErrorCode::kOk, "jog");
  }();
  if (!recording_) return result;
  CardCallRecord r = record(CardCall::kJog);
  r.velocities.assign(axes.begin(), axes.end());
  r.jog_profile = profile;
  return logged(std::move(r), result);
}

ErrorCode MockMotionCard::smooth_stop(std::span<const int> axes) noexcept {
  return axes_call(CardCall::kSmoothStop, "smooth_stop", axes, [&]() noexcept {
    AJAR_MOCK_TRY(check_open("smooth_stop"));
    if (take_drop(CardCall::kSmoothStop)) return check_axes(axes, "smooth_stop");
    const std::int64_t t0 = now_ns();
    for (const int n : axes) {
      if (!valid(n)) continue;
      Axis& a = axis(n);
      a.smooth_stopped = true;
      if (!a.moving || a.stop_held) continue;
      double velocity = 0;
      const double here = sample(a, &velocity);
      if (!a.moving) continue;
      if (stops_never_rest_) {  // reports moving (stopping) until the test clears it
        a.rest_position = here;
        a.stuck = a.stop_held = true;
      } else if (a.stuck) {
        halt(a);
      } else if (model_ == MockMotionModel::kConstantSpeed) {
        if (stop_delay_ns_ == 0 || velocity == 0) {
          halt(a);
        } else {
          const double delay_ms = static_cast<double>(stop_delay_ns_) / 1e6;
          a.motion = profile::plan_stop(t0, here, velocity, std::fabs(velocity) / delay_ms);
        }
      } else {
        a.motion = profile::plan_stop(t0, here, velocity, a.stop_dec);
        (void)sample(a, &velocity);
      }
    }
    return applied_result(CardCall::kSmoothStop, check_axes(axes, "smooth_stop"), "smooth_stop");
  });
}

ErrorCode MockMotionCard::emergency_stop(std::span<const int> axes) noexcept {
  return axes_call(CardCall::kEmergencyStop, "emergency_stop", axes, [&]() noexcept {
    AJAR_MOCK_TRY(check_open("emergency_stop"));
    if (take_drop(CardCall::kEmergencyStop)) return check_axes(axes, "emergency_stop");
    for (const int n : axes) {
      if (!valid(n)) continue;
      Axis& a = axis(n);
      halt(a);
      a.emergency_stopped = true;
    }
    return check_axes(axes, "emergency_stop");
  });
}

ErrorCode MockMotionCard::emergency_stop_out_of_band(std::span<const int> axes) noexcept {
  // Not through enter(): never hangs, no fault menu. A call hanging in hang_if_blocked() waits
  // with the lock released, so this one gets it.
  const Lock lock(mutex_);
  ++calls_;
  ++calls_by_kind_[static_cast<std::size_t>(CardCall::kEmergencyStopOutOfBand)];
  ErrorCode result = ErrorCode::kDriverError;  // not open
  if (open_) {
    result = ErrorCode::kCardBadParameter;  // no valid axis
    for (const int n : axes) {
      if (!valid(n)) continue;
      Axis& a = axis(n);
      halt(a);
      a.emergency_stopped = true;
      result = ErrorCode::kOk;
    }
  }
  return recording_ ? logged(record(CardCall::kEmergencyStopOutOfBand, axes), result) : result;
}

ErrorCode MockMotionCard::axis_status(int n, AxisStatus& out) noexcept {
  Lock lock;
  AJAR_MOCK_TRY(enter(lock, CardCall::kAxisStatus, "axis_status", true));
  const int one[] = {n};
  AJAR_MOCK_TRY(check_axes(one, "axis_status"));
  Axis& a = axis(n);
  if (a.stale_reads > 0 && a.has_last_status) {  // a stale answer: the last one again
    --a.stale_reads;
    out = a.last_status;
    return ErrorCode::kOk;
  }
  if (a.enable_pending > 0 && --a.enable_pending == 0) a.enabled = !a.alarm;
  AxisStatus st = status_of(a);
  if (fault_ == MockFault::kGarbage) {
    garbage_state_ = garbage_state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    const std::uint64_t r = garbage_state_ >> 16;
    st.moving = true;
    st.in_position = true;  // contradictory on purpose
    st.enabled = (r & 1) != 0;
    st.positive_limit = st.negative_limit = (r & 2) != 0;
    st.profile_position_counts = static_cast<std::int64_t>(r % 2000000001ULL) - 1000000000;
    st.encoder_position_counts = -st.profile_position_counts;
  }
  a.last_status = st;
  a.has_last_status = true;
  out = st;
  return ErrorCode::kOk;
}

#undef AJAR_MOCK_TRY

}  // namespace ajar::drivers
