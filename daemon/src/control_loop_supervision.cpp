// The control loop's supervision: reading both axes (odometry), the per-cycle checks of a running
// motion (deadman, card faults, following error, deadlines), stops and the fault latch.
#include <algorithm>
#include <cmath>

#include "ajar/core/geometry.hpp"
#include "ajar/daemon/control_loop.hpp"

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
    report({LoopReportKind::kFault, code, motion_id_, axis, recover_sequence_});
  }
  if (recovery_ != Recovery::kNone) end_recovery(code);  // a fault during recovery ends it
}

void ControlLoop::finish(LoopReportKind kind, ErrorCode code, bool command_timeout) noexcept {
  report({kind, code, motion_id_, 0, 0, command_timeout});
  snapshot_.last_motion_id = motion_id_;
  motion_ = Motion::kIdle;
  jog_command_ = {};
}

void ControlLoop::begin_stop(std::int64_t now_ns) noexcept {
  jog_command_ = {};
  if ((card_.smooth_stop(axes_)) != ErrorCode::kOk) (void)(card_.emergency_stop(axes_));
  motion_ = Motion::kStopping;
  motion_deadline_ns_ = now_ns + stop_timeout_ns_;
}

void ControlLoop::handle_stops(std::int64_t now_ns) noexcept {
  // Latch generation first: every emergency or fault stop it counts is visible below.
  const std::uint32_t latches = latch_generation_.load();
  if (const std::uint32_t e = emergency_generation_.load(); e != handled_emergency_) {
    handled_emergency_ = e;
    (void)(card_.emergency_stop(axes_));
    jog_command_ = {};
    if (motion_ != Motion::kIdle) {
      stop_reason_ = ErrorCode::kEmergencyStopped;
      motion_ = Motion::kStopping;
      motion_deadline_ns_ = now_ns + stop_timeout_ns_;
    }
    latch(ErrorCode::kEmergencyStopped, 0);
  }
  if (latches != handled_latch_) {
    handled_latch_ = latches;
    if (stall_pending_.exchange(false)) {   // the supervisor stopped the card out of band
      (void)(card_.emergency_stop(axes_));  // and now in band: it may not have taken that one
      jog_command_ = {};
      if (motion_ != Motion::kIdle) {
        stop_reason_ = ErrorCode::kLoopStalled;
        motion_ = Motion::kStopping;
        motion_deadline_ns_ = now_ns + stop_timeout_ns_;
      }
      latch(ErrorCode::kLoopStalled, 0);
    }
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

void ControlLoop::read_axes() noexcept {
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
  }
}

void ControlLoop::supervise(std::int64_t now_ns) noexcept {
  const drivers::AxisStatus* status = status_;
  const bool answered = answered_;
  const ErrorCode read_error = read_error_;
  const bool silent = now_ns - heartbeat_ns_.load(std::memory_order_acquire) > deadman_ns_;
  switch (motion_) {
    case Motion::kMoving:
    case Motion::kJogging: {
      ErrorCode fault = ErrorCode::kOk;
      int axis = 0;
      if (!answered) {
        fault = read_error == ErrorCode::kOk ? ErrorCode::kCardCommunication : read_error;
      } else {
        for (int i = 0; i < 2 && fault == ErrorCode::kOk; ++i) {
          if (status[i].alarm)
            fault = ErrorCode::kAxisAlarm;
          else if (status[i].following_error)
            fault = ErrorCode::kFollowingError;
          else if (status[i].positive_limit || status[i].negative_limit)
            fault = ErrorCode::kLimitHit;
          if (fault != ErrorCode::kOk) axis = axes_[i];
        }
      }
      if (fault == ErrorCode::kOk && silent) fault = ErrorCode::kDeadman;
      if (fault == ErrorCode::kOk && motion_ == Motion::kMoving && now_ns > motion_deadline_ns_)
        fault = ErrorCode::kMotionTimeout;
      if (fault != ErrorCode::kOk) {
        latch(fault, axis);
        stop_reason_ = fault;
        begin_stop(now_ns);
        break;
      }
      if (motion_ == Motion::kJogging) break;  // advance_jog ends a jog
      if (status[0].moving || status[1].moving) seen_moving_ = true;
      const bool at_rest =
          !status[0].moving && !status[1].moving && status[0].in_position && status[1].in_position;
      const bool reached = status[0].profile_position_counts == target_counts_[0] &&
                           status[1].profile_position_counts == target_counts_[1];
      if (at_rest && (seen_moving_ || reached))
        finish(LoopReportKind::kMotionFinished, ErrorCode::kOk);
      break;
    }
    case Motion::kStopping:
      if (answered && !status[0].moving && !status[1].moving) {
        finish(LoopReportKind::kMotionStopped, stop_reason_);
      } else if (now_ns > motion_deadline_ns_) {
        (void)(card_.emergency_stop(axes_));
        latch(ErrorCode::kMotionTimeout, 0);
        finish(LoopReportKind::kMotionStopped, ErrorCode::kMotionTimeout);
      }
      break;
    case Motion::kIdle:
      if (fault_ != ErrorCode::kOk) break;
      if (arm_moving_.load(std::memory_order_acquire) && silent) {
        latch(ErrorCode::kDeadman, 0);
      } else if (answered && recovery_ == Recovery::kNone) {  // a recovery checks alarms itself
        for (int i = 0; i < 2; ++i) {
          if (status[i].alarm) {
            latch(ErrorCode::kAxisAlarm, axes_[i]);
            break;
          }
        }
      }
      break;
  }
}

}  // namespace ajar::daemon
