#include "ajar/drivers/mock_card.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>

#include "ajar/drivers/card_checks.hpp"

namespace ajar::drivers {

using card::axis_error;

MockMotionCard::MockMotionCard(MockFault fault, int slow_ms, double time_scale, int axis_count)
    : fault_(fault),
      slow_ms_(std::max(0, slow_ms)),
      time_scale_(time_scale > 0 && std::isfinite(time_scale) ? time_scale : 1.0),
      axis_count_(std::clamp(axis_count, 1, 32)),
      axes_(static_cast<std::size_t>(axis_count_)) {}

double MockMotionCard::now_ms() const {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - epoch_)
             .count() *
         time_scale_;
}

MockMotionCard::Segment MockMotionCard::plan(double t0_ms, double p0, double v0, double vmax,
                                             double acc, double dec, double distance, int dir) {
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

double MockMotionCard::sample(Axis& a, double* speed) {
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

void MockMotionCard::halt(Axis& a) {
  double speed = 0;
  a.rest_position = std::round(sample(a, &speed));
  a.moving = false;
  a.stuck = false;
}

Status MockMotionCard::enter(bool counts_for_faults) {
  ++calls_;
  if (fault_ == MockFault::kSlow) std::this_thread::sleep_for(std::chrono::milliseconds(slow_ms_));
  if (!counts_for_faults) return Ok{};
  if (fault_ == MockFault::kErrorCode) {
    return make_error(ErrorCode::kDriverError, "", "mock card: injected error code");
  }
  if (fault_ == MockFault::kIntermittent && ++fault_calls_ % 3 == 0) {
    return make_error(
        ErrorCode::kCardCommunication, "",
        "mock card: intermittent failure (call " + std::to_string(fault_calls_) + ")");
  }
  return Ok{};
}

Status MockMotionCard::check_axes(std::span<const int> axes) const {
  if (!open_) return make_error(ErrorCode::kDriverError, "", "mock card is not open");
  return card::check_axes(axes, axis_count_);
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
  if (auto s = enter(false); !s) return s;
  // Like GT_Open + GT_Reset + GT_ClrSts: axes off at position 0, no faults.
  open_ = true;
  for (Axis& a : axes_)
    a = Axis{};
  return Ok{};
}

Status MockMotionCard::close() {
  if (auto s = enter(false); !s) return s;
  open_ = false;
  return Ok{};
}

Status MockMotionCard::enable_axes(std::span<const int> axes) {
  if (auto s = enter(true); !s) return s;
  if (auto s = check_axes(axes); !s) return s;
  for (const int axis : axes) {
    Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
    if (a.alarm) return axis_error(ErrorCode::kAxisAlarm, axis, "drive alarm while enabling");
    a.enabled = true;
  }
  return Ok{};
}

Status MockMotionCard::disable_axes(std::span<const int> axes) {
  if (auto s = enter(true); !s) return s;
  if (auto s = check_axes(axes); !s) return s;
  for (const int axis : axes) {
    Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
    halt(a);
    a.enabled = false;
  }
  return Ok{};
}

Status MockMotionCard::clear_faults(std::span<const int> axes) {
  if (auto s = enter(true); !s) return s;
  if (auto s = check_axes(axes); !s) return s;
  for (const int axis : axes) {
    Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
    a.alarm = a.following_error = a.positive_limit = a.negative_limit = false;
    a.smooth_stopped = a.emergency_stopped = false;
  }
  return Ok{};
}

Status MockMotionCard::move_relative(std::span<const AxisMove> moves,
                                     const TrapezoidProfile& profile) {
  if (auto s = enter(true); !s) return s;
  if (!open_) return make_error(ErrorCode::kDriverError, "", "mock card is not open");
  if (auto s = card::check_move(moves, profile, axis_count_); !s) return s;
  for (const AxisMove& m : moves) {
    const Axis& a = axes_[static_cast<std::size_t>(m.axis - 1)];
    AxisStatus st;
    st.enabled = a.enabled;
    st.alarm = a.alarm;
    st.following_error = a.following_error;
    st.positive_limit = a.positive_limit;
    st.negative_limit = a.negative_limit;
    st.emergency_stopped = a.emergency_stopped;
    if (auto s = card::check_can_move(st, m.axis, m.distance_counts); !s) return s;
  }
  const double t0 = now_ms();
  for (const AxisMove& m : moves) {
    Axis& a = axes_[static_cast<std::size_t>(m.axis - 1)];
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
  return Ok{};
}

Status MockMotionCard::smooth_stop(std::span<const int> axes) {
  if (auto s = enter(true); !s) return s;
  if (!open_) return make_error(ErrorCode::kDriverError, "", "mock card is not open");
  const double t0 = now_ms();
  for (const int axis : axes) {
    if (axis < 1 || axis > axis_count_) continue;
    Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
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
  return check_axes(axes);
}

Status MockMotionCard::emergency_stop(std::span<const int> axes) {
  if (auto s = enter(true); !s) return s;
  if (!open_) return make_error(ErrorCode::kDriverError, "", "mock card is not open");
  for (const int axis : axes) {
    if (axis < 1 || axis > axis_count_) continue;
    Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
    halt(a);
    a.emergency_stopped = true;
  }
  return check_axes(axes);
}

Result<AxisStatus> MockMotionCard::axis_status(int axis) {
  if (auto s = enter(true); !s) return std::move(s).error();
  const int one[] = {axis};
  if (auto s = check_axes(one); !s) return std::move(s).error();
  Axis& a = axes_[static_cast<std::size_t>(axis - 1)];
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
  return st;
}

}  // namespace ajar::drivers
