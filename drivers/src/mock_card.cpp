#include "ajar/drivers/mock_card.hpp"

#include <algorithm>
#include <cmath>
#include <thread>

#include "ajar/drivers/card_checks.hpp"

namespace ajar::drivers {

using card::fail;

MockMotionCard::MockMotionCard(MockFault fault, int slow_ms, double time_scale, int axis_count)
    : fault_(fault),
      slow_ms_(std::max(0, slow_ms)),
      time_scale_(time_scale > 0 && std::isfinite(time_scale) ? time_scale : 1.0),
      axis_count_(std::clamp(axis_count, 1, 32)),
      axes_(static_cast<std::size_t>(axis_count_)) {}

double MockMotionCard::now_ms() const noexcept {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - epoch_)
             .count() *
         time_scale_;
}

MockMotionCard::Segment MockMotionCard::plan(double t0_ms, double p0, double v0, double vmax,
                                             double acc, double dec, double distance,
                                             int dir) noexcept {
  Segment s;
  s.t0_ms = t0_ms;
  s.p0 = p0;
  s.v0 = std::min(v0, vmax);
  s.acc = acc;
  s.dec = dec;
  s.distance = distance;
  s.dir = dir;
  const double d_acc = (vmax * vmax - s.v0 * s.v0) / (2 * acc);
  const double d_dec = vmax * vmax / (2 * dec);
  if (d_acc + d_dec <= distance) {
    s.vpeak = vmax;
    s.t_cruise = (distance - d_acc - d_dec) / vmax;
  } else {
    s.vpeak = std::sqrt(
        std::max(s.v0 * s.v0, (2 * acc * dec * distance + dec * s.v0 * s.v0) / (acc + dec)));
    s.t_cruise = 0;
  }
  s.t_acc = (s.vpeak - s.v0) / acc;
  s.t_dec = s.vpeak / dec;
  return s;
}

double MockMotionCard::sample(Axis& a, double* speed) noexcept {
  *speed = 0;
  if (!a.moving || a.stuck) return a.rest_position;
  const Segment& s = a.segment;
  const double t = now_ms() - s.t0_ms;
  double dist = 0;
  if (t < s.t_acc) {
    dist = s.v0 * t + s.acc * t * t / 2;
    *speed = s.v0 + s.acc * t;
  } else if (t < s.t_acc + s.t_cruise) {
    dist = s.v0 * s.t_acc + s.acc * s.t_acc * s.t_acc / 2 + s.vpeak * (t - s.t_acc);
    *speed = s.vpeak;
  } else if (t < s.t_acc + s.t_cruise + s.t_dec) {
    const double tau = t - s.t_acc - s.t_cruise;
    dist = s.v0 * s.t_acc + s.acc * s.t_acc * s.t_acc / 2 + s.vpeak * s.t_cruise + s.vpeak * tau -
           s.dec * tau * tau / 2;
    *speed = s.vpeak - s.dec * tau;
  } else {
    a.moving = false;
    a.rest_position = s.p0 + s.dir * s.distance;
    return a.rest_position;
  }
  return s.p0 + s.dir * std::min(dist, s.distance);
}

void MockMotionCard::halt(Axis& a) noexcept {
  double speed = 0;
  a.rest_position = std::round(sample(a, &speed));
  a.moving = false;
  a.stuck = false;
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
  if (a.moving && (a.segment.dir > 0) == positive) halt(a);
  (positive ? a.positive_limit : a.negative_limit) = true;
}

Status MockMotionCard::open() {
  (void)enter("open", false);
  // Like GT_Open + GT_Reset + GT_ClrSts: axes off at position 0, no faults.
  open_ = true;
  for (Axis& a : axes_)
    a = Axis{};
  return Ok{};
}

Status MockMotionCard::close() {
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
    const Axis& a = axis(m.axis);
    AxisStatus st;
    st.enabled = a.enabled;
    st.alarm = a.alarm;
    st.following_error = a.following_error;
    st.positive_limit = a.positive_limit;
    st.negative_limit = a.negative_limit;
    st.emergency_stopped = a.emergency_stopped;
    AJAR_MOCK_TRY(card::check_can_move(st, m.axis, m.distance_counts, "move_relative", last_));
  }
  const double t0 = now_ms();
  for (const AxisMove& m : moves) {
    Axis& a = axis(m.axis);
    double speed = 0;
    const double here = sample(a, &speed);
    const double goal = std::round(here) + static_cast<double>(m.distance_counts);
    const int dir = goal >= here ? 1 : -1;
    if (a.moving && a.segment.dir != dir) speed = 0;
    a.smooth_stopped = false;
    a.stuck = fault_ == MockFault::kStuck;
    a.rest_position = here;
    a.moving = a.stuck || goal != here;
    a.segment =
        plan(t0, here, speed, profile.velocity_counts_per_ms, profile.acceleration_counts_per_ms2,
             profile.deceleration_counts_per_ms2, std::fabs(goal - here), dir);
  }
  return ErrorCode::kOk;
}

ErrorCode MockMotionCard::smooth_stop(std::span<const int> axes) noexcept {
  AJAR_MOCK_TRY(enter("smooth_stop", true));
  AJAR_MOCK_TRY(check_open("smooth_stop"));
  const double t0 = now_ms();
  for (const int n : axes) {
    if (n < 1 || n > axis_count_) continue;
    Axis& a = axis(n);
    a.smooth_stopped = true;
    if (!a.moving) continue;
    if (a.stuck) {
      halt(a);
      continue;
    }
    double speed = 0;
    const double here = sample(a, &speed);
    if (!a.moving) continue;
    const double dec = a.segment.dec;
    a.segment = plan(t0, here, speed, speed, dec, dec, speed * speed / (2 * dec), a.segment.dir);
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
