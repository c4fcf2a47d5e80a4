// The control loop's supervision: reading both axes (odometry), the per-cycle checks of a running
// motion (deadman, card faults, following error, deadlines), stops and the fault latch.
#include <algorithm>
#include <cmath>

#include "ajar/core/geometry.hpp"
#include "ajar/daemon/control_loop.hpp"
#include "control_loop_units.hpp"

namespace ajar::daemon {

void ControlLoop::report(const LoopReport& r) noexcept {
  if (!reports_.push(r)) ++reports_dropped_;
}

void ControlLoop::latch(ErrorCode code, int axis) noexcept {
  if (fault_ == ErrorCode::kOk && stall_pending_.load()) {
    code = ErrorCode::kLoopStalled;  // what a call that hung reports once it returns
    axis = 0;
  }
  if (fault_ == ErrorCode::kOk) {  // the first fault is the root cause
    fault_ = code;
    report({LoopReportKind::kFault, code, motion_id_, axis, recovery_.sequence()});
  }
  if (recovery_.running()) end_recovery(code);  // a fault during recovery ends it
}

void ControlLoop::finish(LoopReportKind kind, ErrorCode code, bool command_timeout) noexcept {
  report({kind, code, motion_id_, 0, 0, command_timeout});
  snapshot_.last_motion_id = motion_id_;
  motion_ = Motion::kIdle;
  jog_.zero_command();
}

void ControlLoop::enter_stopping(std::int64_t now_ns) noexcept {
  if (motion_ != Motion::kStopping) {  // the running motion's deceleration, its wheels' speed now
    stop_dec_counts_per_ms2_ = motion_ == Motion::kJogging
                                   ? jog_.profile().deceleration_counts_per_ms2
                                   : move_profile_.deceleration_counts_per_ms2;
    for (int i = 0; i < 2; ++i) {
      stop_from_counts_per_ms_[i] =
          measured_valid_ ? std::fabs(measured_counts_per_ms_[i]) : max_wheel_counts_per_ms_;
    }
  }
  stop_begin_ns_ = now_ns;
  smooth_stop_ = false;  // begin_stop() says when it is one
  jog_.stopping();
  motion_ = Motion::kStopping;
  // From the running motion's top speed at its deceleration, as the card was told.
  motion_deadline_ns_ = now_ns + seconds_to_ns(stop_time_s_ * 1.5 / card_scale_) + margin_ns_;
  snapshot_.rest_not_before_ns = now_ns + seconds_to_ns(stop_time_s_ / card_scale_);
}

void ControlLoop::begin_stop(std::int64_t now_ns) noexcept {
  const ErrorCode smooth_error = card_.smooth_stop(axes_);
  const bool smooth = smooth_error == ErrorCode::kOk;
  stop_sent_ = smooth || send_emergency_stop(now_ns);
  enter_stopping(now_ns);
  smooth_stop_ = smooth;
  mismatch_since_ns_[0] = mismatch_since_ns_[1] = -1;
  // A stop the card answered with an error latches it, as a move or a jog does (its lifecycle
  // wrapper latches a communication error too, refusing every move until a Reset recovers it).
  if (!smooth) latch(smooth_error, 0);
}

bool ControlLoop::send_emergency_stop(std::int64_t now_ns) noexcept {
  const bool taken = card_.emergency_stop(axes_) == ErrorCode::kOk;
  if (taken && estop_taken_ns_ < 0) estop_taken_ns_ = now_ns;
  return taken;
}

bool ControlLoop::encoders_at_rest() const noexcept {
  if (!answered_ || !measured_valid_) return false;
  const double dt_ms = static_cast<double>(period_ns_) / 1e6 * card_scale_;
  const double tolerance = settings_.velocity_tolerance * max_wheel_counts_per_ms_ + 2.0 / dt_ms;
  return std::fabs(measured_counts_per_ms_[0]) <= tolerance &&
         std::fabs(measured_counts_per_ms_[1]) <= tolerance;
}

void ControlLoop::check_stopped_wheels(std::int64_t now_ns) noexcept {
  if (estop_taken_ns_ < 0 || !answered_ || !measured_valid_) return;
  if (encoders_at_rest()) {
    estop_taken_ns_ = -1;
    snapshot_.unstopped = false;
    return;
  }
  if (now_ns - estop_taken_ns_ < mismatch_ns_) return;
  // The card took an emergency stop and the wheels still turn: their servos off, the strongest
  // the card allows (the drives stop powering the motors), every cycle until they rest.
  snapshot_.unstopped = true;
  (void)card_.disable_axes(axes_);
  latch(ErrorCode::kVelocityMismatch, 0);
}

void ControlLoop::emergency_fault(ErrorCode code, int axis, std::int64_t now_ns) noexcept {
  latch(code, axis);
  stop_sent_ = send_emergency_stop(now_ns);
  if (motion_ == Motion::kIdle) return;  // the idle check keeps stopping wheels that move
  stop_reason_ = code;
  enter_stopping(now_ns);
}

void ControlLoop::handle_stops(std::int64_t now_ns) noexcept {
  // An emergency stop the card did not take (it did not answer) is sent again every cycle.
  if (estop_pending_) estop_pending_ = !send_emergency_stop(now_ns);
  // Latch generation first: every emergency or fault stop it counts is visible below.
  const std::uint32_t latches = latch_generation_.load();
  if (const std::uint32_t e = emergency_generation_.load(); e != handled_emergency_) {
    handled_emergency_ = e;
    const bool sent = send_emergency_stop(now_ns);
    estop_pending_ = !sent;
    jog_.zero_command();
    if (motion_ != Motion::kIdle) {
      stop_reason_ = ErrorCode::kEmergencyStopped;
      enter_stopping(now_ns);
      stop_sent_ = sent;
    }
    latch(ErrorCode::kEmergencyStopped, 0);
  }
  if (latches != handled_latch_) {
    handled_latch_ = latches;
    // The supervisor stopped the card out of band; now in band too (it may not have taken that).
    if (stall_pending_.exchange(false)) emergency_fault(ErrorCode::kLoopStalled, 0, now_ns);
    ErrorCode queued = ErrorCode::kOk;
    while (fault_codes_.pop(queued)) {
      if (moving()) {
        stop_reason_ = queued;
        begin_stop(now_ns);
      }
      latch(queued, 0);
    }
    if (const auto overflow = fault_overflow_code_.exchange(0); overflow != 0) {
      if (moving()) {
        stop_reason_ = static_cast<ErrorCode>(overflow);
        begin_stop(now_ns);
      }
      latch(static_cast<ErrorCode>(overflow), 0);
    }
  }
  if (const std::uint32_t s = stop_generation_.load(); s != handled_stop_) {
    handled_stop_ = s;
    if (moving()) {
      stop_reason_ = ErrorCode::kOk;
      begin_stop(now_ns);
    }
  }
}

void ControlLoop::read_axes(std::int64_t now_ns) noexcept {
  answered_ = true;
  read_error_ = ErrorCode::kOk;
  for (int i = 0; i < 2; ++i) {
    if (const ErrorCode e = card_.axis_status(axes_[i], status_[i]); e != ErrorCode::kOk) {
      answered_ = false;
      read_error_ = e;
    }
  }
  if (answered_) {
    if (!have_origin_) {
      origin_counts_[0] = status_[0].encoder_position_counts;
      origin_counts_[1] = status_[1].encoder_position_counts;
      have_origin_ = true;
    }
    snapshot_.left_counts = status_[0].encoder_position_counts;
    snapshot_.right_counts = status_[1].encoder_position_counts;
    snapshot_.left_wheel_rad =
        core::counts_to_wheel_rad(status_[0].encoder_position_counts - origin_counts_[0],
                                  settings_.base.left, settings_.base);
    snapshot_.right_wheel_rad =
        core::counts_to_wheel_rad(status_[1].encoder_position_counts - origin_counts_[1],
                                  settings_.base.right, settings_.base);
    snapshot_.base_yaw_rad = core::base_yaw_from_wheels_rad(
        snapshot_.left_wheel_rad, snapshot_.right_wheel_rad, settings_.base);
    snapshot_.pose =
        core::integrate_odometry(snapshot_.pose, snapshot_.left_wheel_rad - last_wheel_rad_[0],
                                 snapshot_.right_wheel_rad - last_wheel_rad_[1], settings_.base);
    snapshot_.pose.yaw_rad = snapshot_.base_yaw_rad;  // exact: linear in the wheel angles
    last_wheel_rad_[0] = snapshot_.left_wheel_rad;
    last_wheel_rad_[1] = snapshot_.right_wheel_rad;
    snapshot_.moving = status_[0].moving || status_[1].moving;
    snapshot_profile_counts_[0] = status_[0].profile_position_counts;
    snapshot_profile_counts_[1] = status_[1].profile_position_counts;
    // The measured velocity: encoder counts since the last answered cycle (the previous one).
    const double dt_ms = static_cast<double>(now_ns - last_read_ns_) / 1e6 * card_scale_;
    const bool consecutive = measured_valid_ || last_read_ns_ != 0;
    measured_valid_ = consecutive && dt_ms > 0 && now_ns - last_read_ns_ <= 3 * period_ns_;
    for (int i = 0; i < 2; ++i) {
      const std::int64_t counts = status_[i].encoder_position_counts;
      measured_counts_per_ms_[i] =
          measured_valid_ ? static_cast<double>(counts - last_encoder_counts_[i]) / dt_ms : 0.0;
      last_encoder_counts_[i] = counts;
    }
    last_read_ns_ = now_ns;
  } else {
    measured_valid_ = false;
    last_read_ns_ = 0;  // the next answered cycle starts the measurement again
  }
}

int ControlLoop::check_velocity(std::int64_t now_ns) noexcept {
  if (!answered_) return 0;
  const double dt_ms = static_cast<double>(period_ns_) / 1e6 * card_scale_;
  for (int i = 0; i < 2; ++i) {
    // What the card was told for this wheel: a velocity band and the ramp toward it.
    double low = 0, high = 0, ramp = 0;
    if (motion_ == Motion::kJogging) {  // between what it was told and its ramp toward it
      low = jog_.band_low(i);
      high = jog_.band_high(i);
      ramp = jog_.profile().acceleration_counts_per_ms2;
    } else if (motion_ == Motion::kMoving) {  // at most the trapezoid's speed, either way
      high = move_profile_.velocity_counts_per_ms;
      low = -high;
      ramp = move_profile_.acceleration_counts_per_ms2;
    } else if (motion_ == Motion::kStopping) {
      // A smooth stop: the wheel's speed along the deceleration from where it was when the stop
      // began. An emergency stop: check_stopped_wheels() supervises it.
      if (!smooth_stop_) {
        mismatch_since_ns_[i] = -1;
        continue;
      }
      const double elapsed_ms = static_cast<double>(now_ns - stop_begin_ns_) / 1e6 * card_scale_;
      high = std::max(0.0, stop_from_counts_per_ms_[i] - stop_dec_counts_per_ms2_ * elapsed_ms);
      low = -high;
      ramp = stop_dec_counts_per_ms2_;
    }
    const double tolerance = settings_.velocity_tolerance * max_wheel_counts_per_ms_ +
                             ramp * settings_.velocity_lag_s * 1e3 + 2.0 / dt_ms;
    const double measured = measured_counts_per_ms_[i];
    const bool off =
        (motion_ == Motion::kIdle && status_[i].moving) ||
        (measured_valid_ && (measured < low - tolerance || measured > high + tolerance));
    if (!off) {
      mismatch_since_ns_[i] = -1;
    } else if (mismatch_since_ns_[i] < 0) {
      mismatch_since_ns_[i] = now_ns;
    }
    if (mismatch_since_ns_[i] >= 0 && now_ns - mismatch_since_ns_[i] >= mismatch_ns_) {
      return axes_[i];
    }
  }
  return 0;
}

bool ControlLoop::past_door_standoff() const noexcept {
  const DoorGuard& guard = jog_.guard();
  if (guard.mode != DoorGuard::Mode::kStandoff || !answered_ || !measured_valid_) return false;
  if (!(door_guard_room_m(guard, snapshot_.pose) < -kDoorStandoffToleranceM)) return false;
  // Still driving forward (toward the door: room is finite only then), measured at the wheels.
  const auto& b = settings_.base;
  const double per_rad_ms = counts_per_wheel_rad_ / 1e3;  // counts/ms per rad/s
  const double left = measured_counts_per_ms_[0] / per_rad_ms * (b.left.polarity < 0 ? -1 : 1);
  const double right = measured_counts_per_ms_[1] / per_rad_ms * (b.right.polarity < 0 ? -1 : 1);
  return b.wheel_radius_m * (left + right) / 2 > 1e-4;
}

void ControlLoop::supervise(std::int64_t now_ns) noexcept {
  supervise_motion(now_ns);
  check_stopped_wheels(now_ns);
}

void ControlLoop::supervise_motion(std::int64_t now_ns) noexcept {
  const bool silent = now_ns - heartbeat_ns_.load(std::memory_order_acquire) > deadman_ns_;
  switch (motion_) {
    case Motion::kMoving:
    case Motion::kJogging:
      return supervise_running(now_ns, silent);
    case Motion::kStopping:
      return supervise_stopping(now_ns);
    case Motion::kIdle:
      return supervise_idle(now_ns, silent);
  }
}

namespace {

// kOk, or the drive fault one axis's status reports: what the card's lifecycle wrapper latches too.
ErrorCode drive_fault(const drivers::AxisStatus& status) noexcept {
  if (status.alarm) return ErrorCode::kAxisAlarm;
  if (status.following_error) return ErrorCode::kFollowingError;
  return ErrorCode::kOk;
}

// kOk, or what one axis's status says stops a running motion: a drive fault or a limit.
ErrorCode axis_fault(const drivers::AxisStatus& status) noexcept {
  if (const ErrorCode fault = drive_fault(status); fault != ErrorCode::kOk) return fault;
  if (status.positive_limit || status.negative_limit) return ErrorCode::kLimitHit;
  return ErrorCode::kOk;
}

}  // namespace

ErrorCode ControlLoop::read_fault() const noexcept {
  return read_error_ == ErrorCode::kOk ? ErrorCode::kCardCommunication : read_error_;
}

ErrorCode ControlLoop::running_fault(bool silent, int& axis) const noexcept {
  if (!answered_) return read_fault();
  for (int i = 0; i < 2; ++i) {
    if (const ErrorCode fault = axis_fault(status_[i]); fault != ErrorCode::kOk) {
      axis = axes_[i];
      return fault;
    }
  }
  return silent ? ErrorCode::kDeadman : ErrorCode::kOk;
}

void ControlLoop::supervise_running(std::int64_t now_ns, bool silent) noexcept {
  int axis = 0;
  if (const ErrorCode fault = running_fault(silent, axis); fault != ErrorCode::kOk) {
    latch(fault, axis);
    stop_reason_ = fault;
    begin_stop(now_ns);
    return;
  }
  // Deadlines (a move's planned duration; a jog told zero coming to rest) and a card that
  // does not do what it was told: it is not trusted with a smooth stop.
  // (A jog held at the standoff, told zero and at rest, has nothing left to do by then.)
  const bool still = !status_[0].moving && !status_[1].moving;
  const bool deadline =
      (motion_ == Motion::kMoving || (jog_.resting() && !still)) && now_ns > motion_deadline_ns_;
  if (deadline) return emergency_fault(ErrorCode::kMotionTimeout, 0, now_ns);
  if (const int off = check_velocity(now_ns); off != 0)
    return emergency_fault(ErrorCode::kVelocityMismatch, off, now_ns);
  if (past_door_standoff()) return emergency_fault(ErrorCode::kVelocityMismatch, 0, now_ns);
  if (motion_ == Motion::kJogging) return;  // advance_jog ends a jog
  finish_move_at_rest();
}

void ControlLoop::finish_move_at_rest() noexcept {
  const drivers::AxisStatus* status = status_;
  if (status[0].moving || status[1].moving) seen_moving_ = true;
  const bool at_rest =
      !status[0].moving && !status[1].moving && status[0].in_position && status[1].in_position;
  const bool reached = status[0].profile_position_counts == target_counts_[0] &&
                       status[1].profile_position_counts == target_counts_[1];
  if (at_rest && (seen_moving_ || reached)) finish(LoopReportKind::kMotionFinished, ErrorCode::kOk);
}

void ControlLoop::supervise_stopping(std::int64_t now_ns) noexcept {
  if (!stop_sent_) {  // again, as an emergency stop
    stop_sent_ = send_emergency_stop(now_ns);
    smooth_stop_ = false;
  }
  // A smooth stop the wheels do not follow (a card that took it and did not apply it):
  // emergency stop now rather than at the stop's deadline.
  if (const int off = check_velocity(now_ns); off != 0) {
    emergency_fault(ErrorCode::kVelocityMismatch, off, now_ns);
    return;
  }
  // A stop that does not stop the base before the door's standoff (a card that did not apply
  // it): emergency stop now rather than at the stop's deadline.
  if (past_door_standoff()) {
    stop_sent_ = send_emergency_stop(now_ns);
    smooth_stop_ = false;
    latch(ErrorCode::kVelocityMismatch, 0);
  }
  // As during a motion: a card that does not answer, a drive fault.
  latch_card_fault();
  if (answered_ && !status_[0].moving && !status_[1].moving) {
    finish(LoopReportKind::kMotionStopped, stop_reason_);
  } else if (now_ns > motion_deadline_ns_) {
    // The stop overran its deadline: emergency stop. Ended once the card took it (a card
    // that keeps its wheels moving after that is stopped again by the idle check, and
    // check_stopped_wheels() switches their servos off).
    stop_sent_ = send_emergency_stop(now_ns);
    smooth_stop_ = false;
    latch(ErrorCode::kMotionTimeout, 0);
    if (stop_sent_) finish(LoopReportKind::kMotionStopped, ErrorCode::kMotionTimeout);
  }
}

void ControlLoop::supervise_idle(std::int64_t now_ns, bool silent) noexcept {
  // Nothing runs: wheels that move anyway (a card that did not apply a stop, or took a command
  // it answered with an error) are emergency-stopped every cycle, and that latches.
  if (const int off = check_velocity(now_ns); off != 0) {
    emergency_fault(ErrorCode::kVelocityMismatch, off, now_ns);
    return;
  }
  if (fault_ != ErrorCode::kOk) return;
  // A card that does not answer latches now, not at the next move the wrapper would refuse
  // (a recovery polls a silent card until its own deadline).
  if (!answered_ && !recovery_.running()) return latch(read_fault(), 0);
  if (arm_moving_.load(std::memory_order_acquire) && silent) {
    latch(ErrorCode::kDeadman, 0);
  } else {
    latch_card_fault();
  }
}

void ControlLoop::latch_card_fault() noexcept {
  if (recovery_.running()) return;  // a recovery watches the card itself
  if (!answered_) return latch(read_fault(), 0);
  for (int i = 0; i < 2; ++i) {
    if (const ErrorCode fault = drive_fault(status_[i]); fault != ErrorCode::kOk)
      return latch(fault, axes_[i]);
  }
}

}  // namespace ajar::daemon
