#include "ajar/drivers/mock_card.hpp"

#include <algorithm>
#include <cmath>
#include <thread>

#include "ajar/drivers/card_checks.hpp"

namespace ajar::drivers {

using card::fail;

MockMotionCard::MockMotionCard(MockFault fault, int slow_ms, double time_scale, int axis_count,
                               MockClock clock)
    : fault_(fault),
      slow_ms_(std::max(0, slow_ms)),
      time_scale_(time_scale > 0 && std::isfinite(time_scale) ? time_scale : 1.0),
      axis_count_(std::clamp(axis_count, 1, 32)),
      clock_(or_steady_clock(std::move(clock))),
      epoch_ns_(clock_()),
      axes_(static_cast<std::size_t>(axis_count_)) {}

std::int64_t MockMotionCard::now_ns() const noexcept {
  if (manual_clock_) return manual_ns_;
  const std::int64_t real_ns = clock_() - epoch_ns_;
  return base_ns_ + std::llround(static_cast<double>(real_ns) * time_scale_);
}

void MockMotionCard::set_manual_clock(bool manual) noexcept {
  const std::int64_t now = now_ns();
  manual_clock_ = manual;
  manual_ns_ = now;
  base_ns_ = now;
  epoch_ns_ = clock_();
}

void MockMotionCard::advance_clock_ns(std::int64_t ns) noexcept {
  if (manual_clock_ && ns > 0) manual_ns_ += ns;
}

double MockMotionCard::sample(Axis& a, double* velocity) noexcept {
  *velocity = 0;
  if (!a.moving || a.stuck) return a.rest_position;
  const profile::Sample s = profile::sample(a.motion, now_ns());
  if (s.done) {
    a.moving = false;
    a.rest_position = s.position;
    return s.position;
  }
  *velocity = s.velocity;
  return s.position;
}

void MockMotionCard::halt(Axis& a) noexcept {
  double velocity = 0;
  a.rest_position = std::round(sample(a, &velocity));
  a.moving = false;
  a.stuck = false;
}

ErrorCode MockMotionCard::check_can_move(int n, double direction, const char* call) noexcept {
  const Axis& a = axis(n);
  AxisStatus st;
  st.enabled = a.enabled;
  st.alarm = a.alarm;
  st.following_error = a.following_error;
  st.positive_limit = a.positive_limit;
  st.negative_limit = a.negative_limit;
  st.emergency_stopped = a.emergency_stopped;
  const std::int64_t sign = direction > 0 ? 1 : (direction < 0 ? -1 : 0);
  return card::check_can_move(st, n, sign, call, last_);
}

ErrorCode MockMotionCard::enter(const char* call, bool realtime) noexcept {
  ++calls_;
  if (fault_ == MockFault::kSlow) std::this_thread::sleep_for(std::chrono::milliseconds(slow_ms_));
  if (!realtime) return ErrorCode::kOk;
  if (fault_ == MockFault::kErrorCode) {
    return fail(last_, ErrorCode::kDriverError, call, 0, "mock card: injected error code");
  }
  if (fault_ == MockFault::kIntermittent && ++fault_calls_ % 3 == 0) {
    return fail(last_, ErrorCode::kCardCommunication, call, 0,
                "mock card: intermittent failure (every third call)");
  }
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::check_open(const char* call) noexcept {
  if (!open_) return fail(last_, ErrorCode::kDriverError, call, 0, "mock card is not open");
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::check_axes(std::span<const int> axes, const char* call) noexcept {
  if (const auto e = check_open(call); e != ErrorCode::kOk) return e;
  return card::check_axes(axes, axis_count_, call, last_);
}

void MockMotionCard::inject_alarm(int axis) {
  if (axis < 1 || axis > axis_count_) return;
  Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
  halt(a);
  a.alarm = true;
  a.enabled = false;
}

void MockMotionCard::inject_following_error(int axis) {
  if (axis < 1 || axis > axis_count_) return;
  Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
  halt(a);
  a.following_error = true;
}

void MockMotionCard::inject_limit(int axis, bool positive) {
  if (axis < 1 || axis > axis_count_) return;
  Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
  if (a.moving && (a.direction > 0) == positive) halt(a);
  (positive ? a.positive_limit : a.negative_limit) = true;
}

Outcome MockMotionCard::open() {
  (void)enter("open", false);
  if (open_fails_) return make_error(ErrorCode::kCardOpenFailed, "", "mock card: no card");
  // Like GT_Open + GT_Reset + GT_ClrSts: axes off at position 0, no faults.
  open_ = true;
  for (Axis& a : axes_)
    a = Axis{};
  return Ok{};
}

Outcome MockMotionCard::close() {
  (void)enter("close", false);
  open_ = false;
  return Ok{};
}

#define AJAR_MOCK_TRY(expr) \
  if (const ErrorCode e_ = (expr); e_ != ErrorCode::kOk) return e_

ErrorCode MockMotionCard::enable_axes(std::span<const int> axes) noexcept {
  AJAR_MOCK_TRY(enter("enable_axes", true));
  AJAR_MOCK_TRY(check_axes(axes, "enable_axes"));
  for (const int n : axes) {  // all checked before any is switched on
    if (axis(n).alarm) {
      return fail(last_, ErrorCode::kAxisAlarm, "enable_axes", n,
                  "drive alarm latched: clear faults first");
    }
  }
  for (const int n : axes)
    axis(n).enabled = true;
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::disable_axes(std::span<const int> axes) noexcept {
  AJAR_MOCK_TRY(enter("disable_axes", true));
  AJAR_MOCK_TRY(check_axes(axes, "disable_axes"));
  for (const int n : axes) {
    Axis& a = axis(n);
    halt(a);
    a.enabled = false;
  }
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::clear_faults(std::span<const int> axes) noexcept {
  AJAR_MOCK_TRY(enter("clear_faults", true));
  AJAR_MOCK_TRY(check_axes(axes, "clear_faults"));
  for (const int n : axes) {
    Axis& a = axis(n);
    a.alarm = a.following_error = a.positive_limit = a.negative_limit = false;
    a.smooth_stopped = a.emergency_stopped = false;
  }
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::move_relative(std::span<const AxisMove> moves,
                                        const TrapezoidProfile& profile) noexcept {
  AJAR_MOCK_TRY(enter("move_relative", true));
  AJAR_MOCK_TRY(check_open("move_relative"));
  AJAR_MOCK_TRY(card::check_move(moves, profile, axis_count_, last_));
  for (const AxisMove& m : moves) {
    AJAR_MOCK_TRY(check_can_move(m.axis, static_cast<double>(m.distance_counts), "move_relative"));
    double velocity = 0;
    Axis& a = axis(m.axis);
    (void)sample(a, &velocity);
    if (a.moving && a.jogging) {  // like the card: no mode change while the axis moves
      return fail(last_, ErrorCode::kDriverError, "move_relative", m.axis,
                  "axis is jogging: stop it first");
    }
  }
  const std::int64_t t0 = now_ns();
  for (const AxisMove& m : moves) {
    Axis& a = axis(m.axis);
    double velocity = 0;
    const double here = sample(a, &velocity);
    const double goal = std::round(here) + static_cast<double>(m.distance_counts);
    a.smooth_stopped = false;
    a.stuck = fault_ == MockFault::kStuck;
    a.jogging = false;
    a.stop_dec = profile.deceleration_counts_per_ms2;
    a.direction = goal >= here ? 1 : -1;
    a.rest_position = here;
    a.motion = profile::plan_trap(t0, here, velocity, goal, profile.velocity_counts_per_ms,
                                  profile.acceleration_counts_per_ms2,
                                  profile.deceleration_counts_per_ms2);
    a.moving = true;
    if (!a.stuck) (void)sample(a, &velocity);  // nothing to do: ends here
  }
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::jog(std::span<const AxisVelocity> axes,
                              const JogProfile& profile) noexcept {
  AJAR_MOCK_TRY(enter("jog", true));
  AJAR_MOCK_TRY(check_open("jog"));
  AJAR_MOCK_TRY(card::check_jog(axes, profile, axis_count_, last_));
  for (const AxisVelocity& v : axes) {
    AJAR_MOCK_TRY(check_can_move(v.axis, v.velocity_counts_per_ms, "jog"));
    double velocity = 0;
    Axis& a = axis(v.axis);
    (void)sample(a, &velocity);
    if (a.moving && !a.jogging) {  // like the card: no mode change while the axis moves
      return fail(last_, ErrorCode::kDriverError, "jog", v.axis,
                  "axis runs a trapezoidal move: stop it first");
    }
  }
  const std::int64_t t0 = now_ns();
  for (const AxisVelocity& v : axes) {
    Axis& a = axis(v.axis);
    double velocity = 0;
    const double here = sample(a, &velocity);
    a.smooth_stopped = false;
    a.stuck = fault_ == MockFault::kStuck && v.velocity_counts_per_ms != 0;
    a.jogging = true;
    a.stop_dec = profile.deceleration_counts_per_ms2;
    a.direction = v.velocity_counts_per_ms != 0 ? profile::sign(v.velocity_counts_per_ms)
                                                : profile::sign(velocity);
    a.rest_position = here;
    a.motion =
        profile::plan_jog(t0, here, velocity, v.velocity_counts_per_ms,
                          profile.acceleration_counts_per_ms2, profile.deceleration_counts_per_ms2);
    a.moving = true;
    if (!a.stuck) (void)sample(a, &velocity);  // nothing to do: ends here
  }
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::smooth_stop(std::span<const int> axes) noexcept {
  AJAR_MOCK_TRY(enter("smooth_stop", true));
  AJAR_MOCK_TRY(check_open("smooth_stop"));
  const std::int64_t t0 = now_ns();
  for (const int n : axes) {
    if (n < 1 || n > axis_count_) continue;
    Axis& a = axis(n);
    a.smooth_stopped = true;
    if (!a.moving) continue;
    if (a.stuck) {
      halt(a);
      continue;
    }
    double velocity = 0;
    const double here = sample(a, &velocity);
    if (!a.moving) continue;
    a.motion = profile::plan_stop(t0, here, velocity, a.stop_dec);
    (void)sample(a, &velocity);
  }
  return check_axes(axes, "smooth_stop");
}

ErrorCode MockMotionCard::emergency_stop(std::span<const int> axes) noexcept {
  AJAR_MOCK_TRY(enter("emergency_stop", true));
  AJAR_MOCK_TRY(check_open("emergency_stop"));
  for (const int n : axes) {
    if (n < 1 || n > axis_count_) continue;
    Axis& a = axis(n);
    halt(a);
    a.emergency_stopped = true;
  }
  return check_axes(axes, "emergency_stop");
}

ErrorCode MockMotionCard::axis_status(int n, AxisStatus& out) noexcept {
  AJAR_MOCK_TRY(enter("axis_status", true));
  const int one[] = {n};
  AJAR_MOCK_TRY(check_axes(one, "axis_status"));
  Axis& a = axis(n);
  double speed = 0;
  const double position = sample(a, &speed);
  AxisStatus st;
  st.enabled = a.enabled;
  st.moving = a.moving;
  st.in_position = !a.moving && a.enabled;
  st.alarm = a.alarm;
  st.following_error = a.following_error;
  st.positive_limit = a.positive_limit;
  st.negative_limit = a.negative_limit;
  st.smooth_stopped = a.smooth_stopped;
  st.emergency_stopped = a.emergency_stopped;
  st.profile_position_counts = std::llround(position);
  st.encoder_position_counts = std::llround(position);
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
  out = st;
  return ErrorCode::kOk;
}

#undef AJAR_MOCK_TRY

}  // namespace ajar::drivers
