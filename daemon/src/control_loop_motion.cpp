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
      jog_.update(c.drive);
      return;
    case CommandKind::kDoorGuard:
      jog_.set_guard(c.guard);
      return;
    case CommandKind::kRecover:
      if (recovery_.running()) end_recovery(ErrorCode::kOk);  // cannot happen: the queue waits
      recovery_.take(c.sequence);
      // An emergency or fault stop posted after it, handled or not yet (read live: a stop posted
      // while this cycle runs must not be cleared by the recovery it followed).
      if (c.latch_stamp != latch_generation_.load()) {
        report({LoopReportKind::kRecovered,
                fault_ != ErrorCode::kOk ? fault_ : ErrorCode::kEmergencyStopped, 0, 0,
                c.sequence});
        return;
      }
      fault_ = ErrorCode::kOk;
      recovery_.begin(c.sequence);
      advance_recovery(now_ns);
      return;
  }
}

void ControlLoop::end_recovery(ErrorCode code) noexcept {
  recovery_.end();
  report({LoopReportKind::kRecovered, code, 0, 0, recovery_.sequence()});
}

void ControlLoop::advance_recovery(std::int64_t now_ns) noexcept {
  using Kind = CardRecovery::Step::Kind;
  // The wheels rest before the servos come back on: no motion supervised, no axis reporting
  // profile motion, and the encoders still (a card whose profile runs on, servo off or not).
  const bool resting = !answered_ || (!status_[0].moving && !status_[1].moving &&
                                      (!measured_valid_ || encoders_at_rest()));
  const CardRecovery::Step step =
      recovery_.next(now_ns, motion_ == Motion::kIdle && resting, answered_, status_);
  switch (step.kind) {
    case Kind::kWait:
      return;
    case Kind::kClearFaults:
      if (const ErrorCode e = card_.clear_faults(axes_); e != ErrorCode::kOk) latch(e, 0);
      return;
    case Kind::kEnableAxes:
      if (const ErrorCode e = card_.enable_axes(axes_); e != ErrorCode::kOk) latch(e, 0);
      return;
    case Kind::kFault:  // also the timeout: latching ends the recovery
      latch(step.code, step.axis_index < 0 ? 0 : axes_[step.axis_index]);
      return;
    case Kind::kRecovered:
      end_recovery(ErrorCode::kOk);
      return;
  }
}

// Why no motion may start in this cycle (kOk: it may). A drive fault seen in this cycle's status
// latches; a status read that failed in this cycle refuses (supervision latches it in this cycle).
ErrorCode ControlLoop::check_can_start() noexcept {
  refused_axis_ = 0;
  if (motion_ != Motion::kIdle) return ErrorCode::kMotionInProgress;
  if (fault_ != ErrorCode::kOk) return ErrorCode::kFaultLatched;
  if (arm_at_door_.load(std::memory_order_acquire)) return ErrorCode::kDriveNotAllowed;
  if (!answered_) return read_fault();
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
    (void)send_emergency_stop(now_ns);
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
  jog_.start(drive, now_ns);
  stop_time_s_ = 0;
  mismatch_since_ns_[0] = mismatch_since_ns_[1] = -1;
  advance_jog(now_ns);
  // A stop posted while the card took the jog acts in this cycle.
  if (stop_generation_.load() != handled_stop_ ||
      emergency_generation_.load() != handled_emergency_)
    handle_stops(now_ns);
}

void ControlLoop::advance_jog(std::int64_t now_ns) noexcept {
  const Jog::Step step = jog_.step(now_ns, snapshot_.pose);
  snapshot_.guard_limiting = step.guard_limiting;
  snapshot_.guard_limit_m_s = step.guard_limit_m_s;
  if (step.send) {
    if (const ErrorCode e = card_.jog(step.axes, jog_.profile()); e != ErrorCode::kOk) {
      // The card may have taken the velocities before it failed: stop it hard.
      return emergency_fault(e, 0, now_ns);
    }
    stop_time_s_ = std::max(stop_time_s_, jog_.sent(step.axes));
  }
  // Told zero just now: the wheels' deadline to come to rest (supervise).
  if (step.rest_s >= 0) {
    motion_deadline_ns_ = now_ns + seconds_to_ns(step.rest_s * 1.5 / card_scale_) + margin_ns_;
  }
  const bool at_rest = answered_ && !status_[0].moving && !status_[1].moving;
  if (step.released && step.told_zero && at_rest && !step.changed) {
    finish(LoopReportKind::kMotionFinished, ErrorCode::kOk, step.ended_by_timeout);
  }
}

}  // namespace ajar::daemon
