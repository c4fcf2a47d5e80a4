// The control loop's motions: executing a queued command, the card's recovery, starting a
// trapezoid move or a jog, and advancing a jog each cycle (docs/control-loop.md, "Jog").
#include <algorithm>
#include <cmath>

#include "ajar/core/driving.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "control_loop_units.hpp"

namespace ajar::daemon {

void ControlLoop::execute(const Command& c, std::int64_t now_ns) noexcept {
  handle_stops(now_ns);  // every stop posted before this command acts first
  switch (c.kind) {
    case CommandKind::kMove:
    case CommandKind::kDriveStart:
      if (c.stop_stamp != handled_stop_) {  // a stop was posted after it: it never starts
        report({LoopReportKind::kMoveCancelled, fault_, c.id(), 0, 0});
        snapshot_.last_motion_id = c.id();
        return;
      }
      if (c.kind == CommandKind::kMove) {
        start_move(c, now_ns);
      } else {
        start_jog(c, now_ns);
      }
      return;
    case CommandKind::kDriveUpdate:
      // Dropped when a stop was posted after it (the stop ends the jog), or when its jog already
      // ended (its terminal report is on the way).
      if (c.stop_stamp != handled_stop_ || motion_ != Motion::kJogging ||
          c.drive.motion_id != motion_id_)
        return;
      jog_target_ = c.drive.velocity;
      jog_stamp_ns_ = c.drive.stamp_ns;
      return;
    case CommandKind::kDoorGuard:
      guard_ = c.guard;
      return;
    case CommandKind::kRecover:
      if (recovery_ != Recovery::kNone) end_recovery(ErrorCode::kOk);  // cannot happen: queue waits
      recover_sequence_ = c.sequence;
      // An emergency or fault stop posted after it, handled or not yet (read live: a stop posted
      // while this cycle runs must not be cleared by the recovery it followed).
      if (c.latch_stamp != latch_generation_.load()) {
        report({LoopReportKind::kRecovered,
                fault_ != ErrorCode::kOk ? fault_ : ErrorCode::kEmergencyStopped, 0, 0,
                c.sequence});
        return;
      }
      fault_ = ErrorCode::kOk;
      recovery_ = Recovery::kWaitRest;
      advance_recovery(now_ns);
      return;
  }
}

void ControlLoop::end_recovery(ErrorCode code) noexcept {
  recovery_ = Recovery::kNone;
  report({LoopReportKind::kRecovered, code, 0, 0, recover_sequence_});
}

void ControlLoop::advance_recovery(std::int64_t now_ns) noexcept {
  if (recovery_ != Recovery::kWaitRest && now_ns > recovery_deadline_ns_) {
    latch(ErrorCode::kMotionTimeout, 0);  // the servo did not come on in time; ends the recovery
    return;
  }
  switch (recovery_) {
    case Recovery::kNone:
      return;
    case Recovery::kWaitRest:  // the wheels come to rest first (a stop has its own deadline)
      if (motion_ != Motion::kIdle) return;
      recovery_ = Recovery::kClear;
      recovery_deadline_ns_ = now_ns + recovery_timeout_ns_;
      [[fallthrough]];
    case Recovery::kClear:
      if (const ErrorCode e = (card_.clear_faults(axes_)); e != ErrorCode::kOk) return latch(e, 0);
      recovery_ = Recovery::kEnable;
      return;
    case Recovery::kEnable:
      if (const ErrorCode e = (card_.enable_axes(axes_)); e != ErrorCode::kOk) return latch(e, 0);
      recovery_ = Recovery::kPoll;
      return;
    case Recovery::kPoll:
      if (!answered_) return;  // not answering: keep polling until the deadline
      for (int i = 0; i < 2; ++i) {
        if (status_[i].alarm) return latch(ErrorCode::kAxisAlarm, axes_[i]);
        if (status_[i].following_error) return latch(ErrorCode::kFollowingError, axes_[i]);
        if (!status_[i].enabled) return;
      }
      end_recovery(ErrorCode::kOk);
      return;
  }
}

// Why no motion may start in this cycle (kOk: it may). A drive fault seen in this cycle's status
// latches; a status read that failed in this cycle refuses without latching (supervision decides
// about a card that stays silent).
ErrorCode ControlLoop::check_can_start() noexcept {
  refused_axis_ = 0;
  if (motion_ != Motion::kIdle) return ErrorCode::kMotionInProgress;
  if (fault_ != ErrorCode::kOk) return ErrorCode::kFaultLatched;
  if (!answered_)
    return read_error_ == ErrorCode::kOk ? ErrorCode::kCardCommunication : read_error_;
  for (int i = 0; i < 2; ++i) {
    const drivers::AxisStatus& st = status_[i];
    const ErrorCode code = st.alarm                                   ? ErrorCode::kAxisAlarm
                           : st.following_error                       ? ErrorCode::kFollowingError
                           : (st.positive_limit || st.negative_limit) ? ErrorCode::kLimitHit
                                                                      : ErrorCode::kOk;
    if (code != ErrorCode::kOk) {
      latch(code, axes_[i]);
      refused_axis_ = axes_[i];
      return code;
    }
  }
  return ErrorCode::kOk;
}

void ControlLoop::start_move(const Command& c, std::int64_t now_ns) noexcept {
  const MoveCommand& move = c.move;
  const auto refuse = [&](ErrorCode code, int axis) {
    report({LoopReportKind::kMoveRefused, code, move.motion_id, axis, 0});
    snapshot_.last_motion_id = move.motion_id;
  };
  if (const ErrorCode e = check_can_start(); e != ErrorCode::kOk) return refuse(e, refused_axis_);
  // The trapezoid the card is told; the deadline and the stop's deadline come from it.
  const drivers::TrapezoidProfile profile = move_profile(move, settings_.base, settings_.drive);
  const drivers::AxisMove moves[2] = {{axes_[0], move.left_counts}, {axes_[1], move.right_counts}};
  if (const ErrorCode e = (card_.move_relative(moves, profile)); e != ErrorCode::kOk) {
    // The card may have taken the move before it failed: nothing may run on unsupervised.
    latch(e, 0);
    (void)card_.emergency_stop(axes_);
    return refuse(e, 0);
  }
  motion_id_ = move.motion_id;
  move_profile_ = profile;
  stop_time_s_ =
      profile.velocity_counts_per_ms / std::max(profile.deceleration_counts_per_ms2, 1e-12) / 1e3;
  target_counts_[0] = snapshot_profile_counts_[0] + move.left_counts;
  target_counts_[1] = snapshot_profile_counts_[1] + move.right_counts;
  seen_moving_ = false;
  stop_reason_ = ErrorCode::kOk;
  motion_ = Motion::kMoving;
  mismatch_since_ns_[0] = mismatch_since_ns_[1] = -1;
  const double planned = std::max(planned_duration_s(move.left_counts, profile),
                                  planned_duration_s(move.right_counts, profile));
  motion_deadline_ns_ = now_ns + seconds_to_ns(planned * 1.5 / card_scale_) + margin_ns_;
  // A stop posted while the card took the move (vendor calls take time) acts in this cycle.
  if (stop_generation_.load() != handled_stop_ ||
      emergency_generation_.load() != handled_emergency_)
    handle_stops(now_ns);
}

void ControlLoop::start_jog(const Command& c, std::int64_t now_ns) noexcept {
  const DriveCommand& drive = c.drive;
  if (const ErrorCode e = check_can_start(); e != ErrorCode::kOk) {
    report({LoopReportKind::kMoveRefused, e, drive.motion_id, refused_axis_, 0});
    snapshot_.last_motion_id = drive.motion_id;
    return;
  }
  motion_id_ = drive.motion_id;
  motion_ = Motion::kJogging;
  stop_reason_ = ErrorCode::kOk;
  jog_target_ = drive.velocity;
  jog_stamp_ns_ = drive.stamp_ns;
  jog_command_ = {};
  jog_last_ns_ = now_ns;
  jog_sent_ = false;
  jog_resting_ = false;
  stop_time_s_ = 0;
  for (int i = 0; i < 2; ++i) {  // from rest (check_can_start saw the status)
    told_counts_per_ms_[i] = expected_counts_per_ms_[i] = 0;
    mismatch_since_ns_[i] = -1;
  }
  advance_jog(now_ns);
  // A stop posted while the card took the jog acts in this cycle.
  if (stop_generation_.load() != handled_stop_ ||
      emergency_generation_.load() != handled_emergency_)
    handle_stops(now_ns);
}

double ControlLoop::guard_forward_limit_m_s() const noexcept {
  if (guard_.mode == DoorGuard::Mode::kStale) return guard_.stale_speed_m_s;
  const double room = door_guard_room_m(guard_, snapshot_.pose);
  if (!std::isfinite(room)) return room;
  if (room <= 0) return 0;
  // Stop within `room` from speed v: v t + v^2 / (2 a) <= room, with the reaction time t.
  const double a = guard_accel_m_s2_, t = guard_reaction_s_;
  return -a * t + std::sqrt(a * a * t * t + 2 * a * room);
}

void ControlLoop::advance_jog(std::int64_t now_ns) noexcept {
  const bool timed_out = now_ns - jog_stamp_ns_ > drive_timeout_ns_;
  const core::BodyVelocity asked = timed_out ? core::BodyVelocity{} : jog_target_;
  core::BodyVelocity target = asked;
  // The door guard: the forward speed it allows from where the base is now.
  const double forward_limit = guard_forward_limit_m_s();
  snapshot_.guard_limiting = target.linear_m_s > forward_limit;
  snapshot_.guard_limit_m_s = std::isfinite(forward_limit) ? forward_limit : 0.0;
  if (snapshot_.guard_limiting) target.linear_m_s = forward_limit;
  const std::int64_t elapsed_ns =
      std::clamp<std::int64_t>(now_ns - jog_last_ns_, 0, 10 * period_ns_);
  const double dt_s = static_cast<double>(elapsed_ns) / kNsPerS;
  jog_last_ns_ = now_ns;
  // The card's ramp toward what it was told (jog_profile_), for the velocity check.
  const double ramp = jog_profile_.acceleration_counts_per_ms2 * static_cast<double>(elapsed_ns) /
                      1e6 * card_scale_;
  for (int i = 0; i < 2; ++i) {
    expected_counts_per_ms_[i] +=
        std::clamp(told_counts_per_ms_[i] - expected_counts_per_ms_[i], -ramp, ramp);
  }
  const core::BodyVelocity next = core::limit_velocity(target, jog_command_, dt_s, settings_.drive);
  const bool changed = next.linear_m_s != jog_command_.linear_m_s ||
                       next.angular_rad_s != jog_command_.angular_rad_s;
  jog_command_ = next;
  if (changed || !jog_sent_) {
    const core::WheelVelocity w = core::wheel_velocity(next, settings_.base);
    const double per_ms = counts_per_wheel_rad_ / 1e3;
    const drivers::AxisVelocity axes[2] = {
        {axes_[0], w.left_rad_s * per_ms * (settings_.base.left.polarity < 0 ? -1 : 1)},
        {axes_[1], w.right_rad_s * per_ms * (settings_.base.right.polarity < 0 ? -1 : 1)}};
    if (const ErrorCode e = card_.jog(axes, jog_profile_); e != ErrorCode::kOk) {
      // The card may have taken the velocities before it failed: stop it hard.
      return emergency_fault(e, 0, now_ns);
    }
    for (int i = 0; i < 2; ++i) {
      told_counts_per_ms_[i] = axes[i].velocity_counts_per_ms;
      // The slowest stop of this jog: from the fastest the card was told, at the jog's ramp.
      stop_time_s_ = std::max(stop_time_s_,
                              std::abs(told_counts_per_ms_[i]) /
                                  std::max(jog_profile_.deceleration_counts_per_ms2, 1e-12) / 1e3);
    }
    jog_sent_ = true;
  }
  // Told zero (released, timed out, or held at the door's standoff): the card ramps the wheels
  // from where they are to rest; a deadline for it (supervise).
  const bool told_zero = next.linear_m_s == 0 && next.angular_rad_s == 0;
  if (!told_zero) {
    jog_resting_ = false;
  } else if (!jog_resting_) {
    jog_resting_ = true;
    double rest_s = 0;
    for (int i = 0; i < 2; ++i) {
      rest_s =
          std::max(rest_s, std::abs(expected_counts_per_ms_[i]) /
                               std::max(jog_profile_.deceleration_counts_per_ms2, 1e-12) / 1e3);
    }
    motion_deadline_ns_ = now_ns + seconds_to_ns(rest_s * 1.5 / card_scale_) + margin_ns_;
  }
  // The jog ends once the operator asks for nothing (a zero Drive or the timeout) and the wheels
  // rest; held at the standoff it stays open while the key is held.
  const bool released = asked.linear_m_s == 0 && asked.angular_rad_s == 0;
  const bool at_rest = answered_ && !status_[0].moving && !status_[1].moving;
  if (released && told_zero && at_rest && !changed) {
    // The timeout ended it only when the last Drive still asked for motion.
    finish(LoopReportKind::kMotionFinished, ErrorCode::kOk,
           timed_out && (jog_target_.linear_m_s != 0 || jog_target_.angular_rad_s != 0));
  }
}

}  // namespace ajar::daemon
