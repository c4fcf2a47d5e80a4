// The control loop's running jog (Jog in ajar/daemon/control_loop.hpp; docs/control-loop.md,
// "Jog").
#include <algorithm>
#include <cmath>

#include "ajar/core/driving.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "control_loop_units.hpp"

namespace ajar::daemon {

Jog::Jog(const ControlLoopSettings& settings, const drivers::JogProfile& profile,
         double counts_per_wheel_rad, double card_scale, std::int64_t period_ns) noexcept
    : settings_(settings),
      profile_(profile),
      counts_per_wheel_rad_(counts_per_wheel_rad),
      card_scale_(card_scale),
      period_ns_(period_ns),
      timeout_ns_(seconds_to_ns(settings.drive.command_timeout_s)),
      // A straight jog's wheels ramp at the jog profile: that, or the limiter's own deceleration
      // (in the card's time), whichever is slower, brakes the base at the door's standoff.
      guard_accel_m_s2_(std::min(settings.drive.max_linear_accel_m_s2 / card_scale,
                                 profile.deceleration_counts_per_ms2 * 1e6 / counts_per_wheel_rad *
                                     settings.base.wheel_radius_m)),
      guard_reaction_s_(3.0 / settings.control.rate_hz * card_scale),
      axes_{settings.base.left.card_axis, settings.base.right.card_axis} {}

void Jog::start(const DriveCommand& drive, std::int64_t now_ns) noexcept {
  target_ = drive.velocity;
  stamp_ns_ = drive.stamp_ns;
  command_ = {};
  last_ns_ = now_ns;
  sent_ = false;
  resting_ = false;
  for (int i = 0; i < 2; ++i)  // from rest (the loop checked the status)
    told_counts_per_ms_[i] = expected_counts_per_ms_[i] = 0;
}

void Jog::update(const DriveCommand& drive) noexcept {
  target_ = drive.velocity;
  stamp_ns_ = drive.stamp_ns;
}

double Jog::guard_forward_limit_m_s(const core::PlanarPose& pose) const noexcept {
  if (guard_.mode == DoorGuard::Mode::kStale) return guard_.stale_speed_m_s;
  const double room = door_guard_room_m(guard_, pose);
  if (!std::isfinite(room)) return room;
  if (room <= 0) return 0;
  // Stop within `room` from speed v: v t + v^2 / (2 a) <= room, with the reaction time t.
  const double a = guard_accel_m_s2_, t = guard_reaction_s_;
  return -a * t + std::sqrt(a * a * t * t + 2 * a * room);
}

Jog::Step Jog::step(std::int64_t now_ns, const core::PlanarPose& pose) noexcept {
  Step st;
  const bool timed_out = now_ns - stamp_ns_ > timeout_ns_;
  const core::BodyVelocity asked = timed_out ? core::BodyVelocity{} : target_;
  core::BodyVelocity target = asked;
  // The door guard: the forward speed it allows from where the base is now.
  const double forward_limit = guard_forward_limit_m_s(pose);
  st.guard_limiting = target.linear_m_s > forward_limit;
  st.guard_limit_m_s = std::isfinite(forward_limit) ? forward_limit : 0.0;
  if (st.guard_limiting) target.linear_m_s = forward_limit;
  const std::int64_t since_ns = std::max<std::int64_t>(now_ns - last_ns_, 0);
  last_ns_ = now_ns;
  // The limiter steps at most 10 periods' worth after a late cycle (no jump in the command) ...
  const double dt_s = static_cast<double>(std::min(since_ns, 10 * period_ns_)) / kNsPerS;
  // ... but the card ramped toward what it was told (profile_) the whole time, also while the loop
  // made no cycle (a starved thread): the velocity check's model of it runs on in its time.
  const double ramp =
      profile_.acceleration_counts_per_ms2 * static_cast<double>(since_ns) / 1e6 * card_scale_;
  for (int i = 0; i < 2; ++i) {
    expected_counts_per_ms_[i] +=
        std::clamp(told_counts_per_ms_[i] - expected_counts_per_ms_[i], -ramp, ramp);
  }
  const core::BodyVelocity next = core::limit_velocity(target, command_, dt_s, settings_.drive);
  st.changed =
      next.linear_m_s != command_.linear_m_s || next.angular_rad_s != command_.angular_rad_s;
  command_ = next;
  if (st.changed || !sent_) {
    const core::WheelVelocity w = core::wheel_velocity(next, settings_.base);
    const double per_ms = counts_per_wheel_rad_ / 1e3;
    st.send = true;
    st.axes[0] = {axes_[0], w.left_rad_s * per_ms * (settings_.base.left.polarity < 0 ? -1 : 1)};
    st.axes[1] = {axes_[1], w.right_rad_s * per_ms * (settings_.base.right.polarity < 0 ? -1 : 1)};
  }
  // Told zero (released, timed out, or held at the door's standoff): the card ramps the wheels
  // from where they are to rest; the loop supervises that with a deadline.
  st.told_zero = next.linear_m_s == 0 && next.angular_rad_s == 0;
  if (!st.told_zero) {
    resting_ = false;
  } else if (!resting_) {
    resting_ = true;
    st.rest_s = 0;
    for (int i = 0; i < 2; ++i) {
      st.rest_s =
          std::max(st.rest_s, std::abs(expected_counts_per_ms_[i]) /
                                  std::max(profile_.deceleration_counts_per_ms2, 1e-12) / 1e3);
    }
  }
  // The jog ends once the operator asks for nothing (a zero Drive or the timeout) and the wheels
  // rest; held at the standoff it stays open while the key is held. The timeout ended it only when
  // the last Drive still asked for motion.
  st.released = asked.linear_m_s == 0 && asked.angular_rad_s == 0;
  st.ended_by_timeout = timed_out && (target_.linear_m_s != 0 || target_.angular_rad_s != 0);
  return st;
}

double Jog::sent(const drivers::AxisVelocity (&axes)[2]) noexcept {
  double stop_s = 0;
  for (int i = 0; i < 2; ++i) {
    told_counts_per_ms_[i] = axes[i].velocity_counts_per_ms;
    // The slowest stop of this jog: from the fastest the card was told, at the jog's ramp.
    stop_s = std::max(stop_s, std::abs(told_counts_per_ms_[i]) /
                                  std::max(profile_.deceleration_counts_per_ms2, 1e-12) / 1e3);
  }
  sent_ = true;
  return stop_s;
}

}  // namespace ajar::daemon
