#include "ajar/daemon/control_loop.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <numbers>

#include "ajar/core/geometry.hpp"
#include "ajar/daemon/realtime.hpp"

namespace ajar::daemon {
namespace {

constexpr double kNsPerS = 1e9;

std::int64_t seconds_to_ns(double s) noexcept {
  return std::llround(s * kNsPerS);
}

// Motor counts per radian at the wheel.
double counts_per_wheel_rad(const core::BaseGeometry& base) noexcept {
  return base.gear_ratio * base.encoder_counts_per_rev / (2.0 * std::numbers::pi);
}

}  // namespace

drivers::TrapezoidProfile wheel_profile(const core::BaseGeometry& base) noexcept {
  const double per_rad = counts_per_wheel_rad(base);
  drivers::TrapezoidProfile profile;
  profile.velocity_counts_per_ms = base.max_wheel_speed_rad_s * per_rad / 1e3;
  profile.acceleration_counts_per_ms2 = base.max_wheel_accel_rad_s2 * per_rad / 1e6;
  profile.deceleration_counts_per_ms2 = profile.acceleration_counts_per_ms2;
  profile.smooth_time_ms = 0;
  return profile;
}

drivers::TrapezoidProfile straight_profile(const core::BaseGeometry& base,
                                           const core::DriveLimits& drive) noexcept {
  const double per_rad = counts_per_wheel_rad(base);
  drivers::TrapezoidProfile profile = wheel_profile(base);
  profile.velocity_counts_per_ms =
      std::min(profile.velocity_counts_per_ms,
               drive.max_linear_speed_m_s / base.wheel_radius_m * per_rad / 1e3);
  profile.acceleration_counts_per_ms2 =
      std::min(profile.acceleration_counts_per_ms2,
               drive.max_linear_accel_m_s2 / base.wheel_radius_m * per_rad / 1e6);
  profile.deceleration_counts_per_ms2 = profile.acceleration_counts_per_ms2;
  return profile;
}

double planned_duration_s(std::int64_t distance_counts,
                          const drivers::TrapezoidProfile& profile) noexcept {
  const double d = std::abs(static_cast<double>(distance_counts));
  const double v = profile.velocity_counts_per_ms;
  const double a =
      std::min(profile.acceleration_counts_per_ms2, profile.deceleration_counts_per_ms2);
  if (d == 0 || v <= 0 || a <= 0) return 0;
  const double ramp_distance = v * v / a;  // accelerate to v and decelerate back to 0
  const double ms = d >= ramp_distance ? d / v + v / a : 2.0 * std::sqrt(d / a);
  return ms / 1e3;
}

ControlLoop::ControlLoop(drivers::MotionCard& card, const ControlLoopSettings& settings)
    : card_(card),
      settings_(settings),
      axes_{settings.base.left.card_axis, settings.base.right.card_axis},
      profile_(wheel_profile(settings.base)),
      straight_profile_(straight_profile(settings.base, settings.drive)),
      jog_profile_{profile_.acceleration_counts_per_ms2, profile_.deceleration_counts_per_ms2, 0},
      counts_per_wheel_rad_(counts_per_wheel_rad(settings.base)),
      drive_timeout_ns_(seconds_to_ns(settings.drive.command_timeout_s)),
      period_ns_(std::max<std::int64_t>(1, std::llround(kNsPerS / settings.rate_hz))),
      deadman_ns_(seconds_to_ns(settings.deadman_timeout_s)),
      stop_timeout_ns_(
          seconds_to_ns(1.5 * (profile_.velocity_counts_per_ms /
                               std::max(profile_.deceleration_counts_per_ms2, 1e-12) / 1e3) +
                        settings.motion_timeout_margin_s)),
      recovery_timeout_ns_(seconds_to_ns(settings.recovery_timeout_s)),
      statistics_(settings.rate_hz) {}

ControlLoop::~ControlLoop() {
  stop_thread();
}

std::vector<std::string> ControlLoop::start_thread() {
  if (thread_.joinable()) return {};
  exit_requested_.store(false);
  std::promise<std::vector<std::string>> warnings;
  auto ready = warnings.get_future();
  const RealtimeRequest request{settings_.realtime, settings_.priority, settings_.lock_memory};
  last_cycle_end_ns_.store(monotonic_now_ns());
  thread_ = std::thread([this, request, promise = std::move(warnings)]() mutable {
    auto refused = apply_realtime(request);
    const std::int64_t first = monotonic_now_ns() + period_ns_;
    promise.set_value(std::move(refused));
    thread_main(first);
  });
  auto result = ready.get();
  thread_running_.store(true, std::memory_order_release);
  return result;
}

void ControlLoop::stop_thread() noexcept {
  thread_running_.store(false, std::memory_order_release);
  exit_requested_.store(true);
  if (thread_.joinable()) thread_.join();
}

void ControlLoop::thread_main(std::int64_t first_deadline_ns) noexcept {
  std::int64_t deadline = first_deadline_ns;
  while (!exit_requested_.load(std::memory_order_relaxed)) {
    sleep_until_ns(deadline);
    const std::int64_t wake = monotonic_now_ns();
    cycle(wake);
    const std::int64_t end = monotonic_now_ns();
    statistics_.record_cycle(deadline, wake, end);
    last_cycle_end_ns_.store(end, std::memory_order_release);
    deadline += period_ns_;
    if (end > deadline) {  // missed at least one deadline: count it, skip to the next free slot
      statistics_.record_overrun();
      while (deadline <= end)
        deadline += period_ns_;
    }
  }
}

bool ControlLoop::post_move(const MoveCommand& move) noexcept {
  Command c;
  c.kind = CommandKind::kMove;
  c.id = move.motion_id;
  c.left_counts = move.left_counts;
  c.right_counts = move.right_counts;
  c.stop_stamp = stop_generation_.load();
  c.latch_stamp = latch_generation_.load();
  return commands_.push(c);
}
bool ControlLoop::post_drive(const DriveCommand& drive) noexcept {
  Command c;
  c.kind = drive.start ? CommandKind::kDriveStart : CommandKind::kDriveUpdate;
  c.id = drive.motion_id;
  c.velocity = drive.velocity;
  c.stamp_ns = drive.stamp_ns;
  c.stop_stamp = stop_generation_.load();
  c.latch_stamp = latch_generation_.load();
  return commands_.push(c);
}
bool ControlLoop::request_recover(std::uint32_t sequence) noexcept {
  Command c;
  c.kind = CommandKind::kRecover;
  c.id = sequence;
  c.stop_stamp = stop_generation_.load();
  c.latch_stamp = latch_generation_.load();
  return commands_.push(c);
}
// The generations are bumped after the code is queued: a cycle that sees the new generation sees
// the code too. The emergency generation is bumped before the latch generation for the same reason.
void ControlLoop::request_stop() noexcept {
  stop_generation_.fetch_add(1);
}
void ControlLoop::request_emergency_stop() noexcept {
  emergency_generation_.fetch_add(1);
  stop_generation_.fetch_add(1);
  latch_generation_.fetch_add(1);
}
void ControlLoop::request_fault_stop(ErrorCode code) noexcept {
  if (!fault_codes_.push(code)) {
    std::uint16_t none = 0;
    (void)fault_overflow_code_.compare_exchange_strong(none, static_cast<std::uint16_t>(code));
  }
  stop_generation_.fetch_add(1);
  latch_generation_.fetch_add(1);
}
void ControlLoop::set_arm_moving(bool moving) noexcept {
  arm_moving_.store(moving, std::memory_order_release);
}
bool ControlLoop::pop_report(LoopReport& r) noexcept {
  return reports_.pop(r);
}
void ControlLoop::heartbeat(std::int64_t now_ns) noexcept {
  heartbeat_ns_.store(now_ns, std::memory_order_release);
}

bool ControlLoop::healthy(std::int64_t now_ns) const noexcept {
  if (!thread_running_.load(std::memory_order_acquire)) return false;
  const std::int64_t limit = std::max<std::int64_t>(10 * period_ns_, 20'000'000);
  return now_ns - last_cycle_end_ns_.load(std::memory_order_acquire) <= limit;
}

void ControlLoop::report(const LoopReport& r) noexcept {
  if (!reports_.push(r)) ++reports_dropped_;
}

void ControlLoop::latch(ErrorCode code, int axis) noexcept {
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

void ControlLoop::execute(const Command& c, std::int64_t now_ns) noexcept {
  handle_stops(now_ns);  // every stop posted before this command acts first
  switch (c.kind) {
    case CommandKind::kMove:
    case CommandKind::kDriveStart:
      if (c.stop_stamp != handled_stop_) {  // a stop was posted after it: it never starts
        report({LoopReportKind::kMoveCancelled, fault_, c.id, 0, 0});
        snapshot_.last_motion_id = c.id;
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
      if (c.stop_stamp != handled_stop_ || motion_ != Motion::kJogging || c.id != motion_id_)
        return;
      jog_target_ = c.velocity;
      jog_stamp_ns_ = c.stamp_ns;
      return;
    case CommandKind::kRecover:
      if (recovery_ != Recovery::kNone) end_recovery(ErrorCode::kOk);  // cannot happen: queue waits
      recover_sequence_ = c.id;
      // An emergency or fault stop posted after it, handled or not yet (read live: a stop posted
      // while this cycle runs must not be cleared by the recovery it followed).
      if (c.latch_stamp != latch_generation_.load()) {
        report({LoopReportKind::kRecovered,
                fault_ != ErrorCode::kOk ? fault_ : ErrorCode::kEmergencyStopped, 0, 0, c.id});
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

void ControlLoop::start_move(const Command& move, std::int64_t now_ns) noexcept {
  const auto refuse = [&](ErrorCode code, int axis) {
    report({LoopReportKind::kMoveRefused, code, move.id, axis, 0});
    snapshot_.last_motion_id = move.id;
  };
  if (const ErrorCode e = check_can_start(); e != ErrorCode::kOk) return refuse(e, refused_axis_);
  const drivers::TrapezoidProfile& profile =
      move.profile == MoveProfile::kStraight ? straight_profile_ : profile_;
  const drivers::AxisMove moves[2] = {{axes_[0], move.left_counts}, {axes_[1], move.right_counts}};
  if (const ErrorCode e = (card_.move_relative(moves, profile)); e != ErrorCode::kOk) {
    latch(e, 0);
    return refuse(e, 0);
  }
  motion_id_ = move.id;
  target_counts_[0] = snapshot_profile_counts_[0] + move.left_counts;
  target_counts_[1] = snapshot_profile_counts_[1] + move.right_counts;
  seen_moving_ = false;
  stop_reason_ = ErrorCode::kOk;
  motion_ = Motion::kMoving;
  const double planned = std::max(planned_duration_s(move.left_counts, profile),
                                  planned_duration_s(move.right_counts, profile));
  motion_deadline_ns_ = now_ns + seconds_to_ns(planned * 1.5 + settings_.motion_timeout_margin_s);
  // A stop posted while the card took the move (vendor calls take time) acts in this cycle.
  if (stop_generation_.load() != handled_stop_ ||
      emergency_generation_.load() != handled_emergency_)
    handle_stops(now_ns);
}

void ControlLoop::start_jog(const Command& drive, std::int64_t now_ns) noexcept {
  if (const ErrorCode e = check_can_start(); e != ErrorCode::kOk) {
    report({LoopReportKind::kMoveRefused, e, drive.id, refused_axis_, 0});
    snapshot_.last_motion_id = drive.id;
    return;
  }
  motion_id_ = drive.id;
  motion_ = Motion::kJogging;
  stop_reason_ = ErrorCode::kOk;
  jog_target_ = drive.velocity;
  jog_stamp_ns_ = drive.stamp_ns;
  jog_command_ = {};
  jog_last_ns_ = now_ns;
  jog_sent_ = false;
  advance_jog(now_ns);
  // A stop posted while the card took the jog acts in this cycle.
  if (stop_generation_.load() != handled_stop_ ||
      emergency_generation_.load() != handled_emergency_)
    handle_stops(now_ns);
}

void ControlLoop::advance_jog(std::int64_t now_ns) noexcept {
  const bool timed_out = now_ns - jog_stamp_ns_ > drive_timeout_ns_;
  const core::BodyVelocity target = timed_out ? core::BodyVelocity{} : jog_target_;
  const double dt_s =
      static_cast<double>(std::clamp<std::int64_t>(now_ns - jog_last_ns_, 0, 10 * period_ns_)) /
      kNsPerS;
  jog_last_ns_ = now_ns;
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
      latch(e, 0);
      stop_reason_ = e;
      begin_stop(now_ns);
      return;
    }
    jog_sent_ = true;
  }
  const bool at_rest = answered_ && !status_[0].moving && !status_[1].moving;
  if (next.linear_m_s == 0 && next.angular_rad_s == 0 && target.linear_m_s == 0 &&
      target.angular_rad_s == 0 && at_rest && !changed) {
    // The timeout ended it only when the last Drive still asked for motion.
    finish(LoopReportKind::kMotionFinished, ErrorCode::kOk,
           timed_out && (jog_target_.linear_m_s != 0 || jog_target_.angular_rad_s != 0));
  }
}

void ControlLoop::cycle(std::int64_t now_ns) noexcept {
  read_axes();  // first: odometry and a move's start position come from before any new command
  handle_stops(now_ns);
  if (recovery_ != Recovery::kNone) advance_recovery(now_ns);
  while (recovery_ == Recovery::kNone) {  // the queue waits behind a running recovery
    Command c;
    if (!commands_.pop(c)) break;
    execute(c, now_ns);
  }

  supervise(now_ns);
  if (motion_ == Motion::kJogging) advance_jog(now_ns);

  ++snapshot_.cycles;
  snapshot_.time_ns = now_ns;
  snapshot_.motion_active = motion_ != Motion::kIdle;
  snapshot_.jogging = motion_ == Motion::kJogging;
  snapshot_.commanded = jog_command_;
  snapshot_.fault = fault_;
  snapshot_.recover_sequence = recover_sequence_;
  snapshot_.recovering = recovery_ != Recovery::kNone;
  snapshot_.card_state = card_state();
  snapshot_.reports_dropped = reports_dropped_;
  published_.store(snapshot_);
}

drivers::LifecycleState ControlLoop::card_state() const noexcept {
  if (!answered_) return drivers::LifecycleState::kFault;
  switch (fault_) {
    case ErrorCode::kCardCommunication:
    case ErrorCode::kAxisAlarm:
    case ErrorCode::kFollowingError:
    case ErrorCode::kDriverError:
    case ErrorCode::kDriverNotActive:
      return drivers::LifecycleState::kFault;
    default:
      break;
  }
  if (recovery_ != Recovery::kNone) return drivers::LifecycleState::kInactive;
  return status_[0].enabled && status_[1].enabled ? drivers::LifecycleState::kActive
                                                  : drivers::LifecycleState::kInactive;
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
