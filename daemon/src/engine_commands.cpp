// The engine's commands: every request the procedure answers, the motions it hands to the
// control loop (align, drive, approach), engage, the stops and reset.
#include "engine_impl.hpp"

#include "ajar/protocol/message_table.hpp"

namespace ajar::daemon::detail {

protocol::Message EngineImpl::dispatch(const protocol::Message& request) {
  const MessageType type = protocol::type_of(request);
  if (protocol::policy_of(type).needs_wheels_at_rest && procedure_.fault() == ErrorCode::kOk) {
    if (auto s = check_wheels_at_rest(); !s) return refuse(type, s.error());
  }
  if (const auto* m = std::get_if<protocol::MeasureDoorWidth>(&request)) {
    return answer(type, procedure_.measure_width(*m));
  }
  if (const auto* m = std::get_if<protocol::MeasureHandle>(&request)) {
    return answer(type, procedure_.measure_handle(*m));
  }
  if (const auto* m = std::get_if<protocol::MeasureDoorPlane>(&request)) {
    return answer(type, procedure_.measure_plane(*m));
  }
  if (const auto* m = std::get_if<protocol::SetContactPoint>(&request)) {
    return answer(type, procedure_.set_contact(*m));
  }
  if (std::holds_alternative<protocol::AlignBase>(request)) return align(type);
  if (std::holds_alternative<protocol::Engage>(request)) return engage(type);
  if (std::holds_alternative<protocol::Stop>(request)) return stop(type);
  if (std::holds_alternative<protocol::EmergencyStop>(request)) return emergency_stop(type);
  if (const auto* m = std::get_if<protocol::Reset>(&request)) return reset(type, *m);
  if (const auto* m = std::get_if<protocol::Drive>(&request)) return drive(type, *m);
  if (const auto* m = std::get_if<protocol::Approach>(&request)) return approach(type, *m);
  if (type == MessageType::kResetLoopStatistics) {
    loop_->statistics().reset(monotonic_now_ns());
    return ack(type, protocol::EmptyAck{});
  }
  return refuse(type, make_error(ErrorCode::kWrongState, "", "not a command for the procedure"));
}

protocol::Message EngineImpl::ack(MessageType type, protocol::AckBody body) {
  protocol::Ack a;
  a.acknowledged = type;
  a.state = procedure_.state();
  a.body = std::move(body);
  return a;
}

protocol::Message EngineImpl::refuse(MessageType type, const Error& e) {
  protocol::ErrorReply r;
  r.code = e.code;
  r.offending_type = type;
  r.field.assign(e.field);
  r.message.assign(e.message.empty() ? std::string(to_string(e.code)) : e.message);
  return r;
}

protocol::Message EngineImpl::align(MessageType type) {
  auto wheels = procedure_.check_align();
  if (!wheels) return refuse(type, wheels.error());
  if (auto s = check_wheels_stopped(); !s) return refuse(type, s.error());
  if (wheels->left_counts == 0 && wheels->right_counts == 0) {  // already square to the door
    procedure_.alignment_started();
    procedure_.alignment_finished();
    dirty_ = true;
    return ack(type, protocol::EmptyAck{});
  }
  if (auto s = check_arm_clear(); !s) return refuse(type, s.error());
  loop_->heartbeat(now_ns());  // the controller just spoke
  const MoveCommand move{++motion_id_, wheels->left_counts, wheels->right_counts};
  if (!hand_over(move)) return refuse(type, queue_full());
  procedure_.alignment_started();
  begin_wheel_motion(move.motion_id, WheelKind::kAlign);
  emit(EventKind::kMotionStarted, ErrorCode::kOk,
       "aligning: left " + std::to_string(move.left_counts) + " counts, right " +
           std::to_string(move.right_counts) + " counts");
  dirty_ = true;
  return ack(type, protocol::EmptyAck{});
}

protocol::Message EngineImpl::drive(MessageType type, const protocol::Drive& m) {
  if (auto s = check_base_may_drive(true); !s) return refuse(type, s.error());
  if (auto s = check_door_guard(m); !s) return refuse(type, s.error());
  if (!sync_door_guard()) return refuse(type, queue_full());  // the loop guards this jog
  loop_->heartbeat(now_ns());
  const core::BodyVelocity velocity{m.linear_m_s, m.angular_rad_s};
  const std::int64_t stamp = now_ns();
  if (wheel_motion_ != 0) {  // a running jog: update it
    if (held_drive_ && held_drive_->motion_id == wheel_motion_) {
      held_drive_->velocity = velocity;
      held_drive_->stamp_ns = stamp;
    } else {
      if (!hand_over(DriveCommand{wheel_motion_, false, velocity, stamp})) {
        return refuse(type, queue_full());
      }
    }
    return ack(type, protocol::EmptyAck{});
  }
  if (velocity.linear_m_s == 0 && velocity.angular_rad_s == 0) {
    return ack(type, protocol::EmptyAck{});  // at rest already: nothing to do
  }
  const DriveCommand start{motion_id_ + 1, true, velocity, stamp};
  if (!hand_over(start)) return refuse(type, queue_full());
  ++motion_id_;
  begin_wheel_motion(start.motion_id, WheelKind::kJog);
  emit(EventKind::kMotionStarted, ErrorCode::kOk,
       fmt::format("driving: {:.3f} m/s, {:.3f} rad/s asked (limits {:.3f} m/s, {:.3f} rad/s){}",
                   m.linear_m_s, m.angular_rad_s, config_.drive.max_linear_speed_m_s,
                   config_.drive.max_angular_speed_rad_s, door_guard_clause()));
  return ack(type, protocol::EmptyAck{});
}

DoorGuard EngineImpl::door_guard() const {
  DoorGuard g;
  const auto line = procedure_.door_line();
  if (!line) return g;  // no door known: nothing to guard against
  if (procedure_.plane() && procedure_.staleness(loop_->snapshot().pose).plane) {
    g.mode = DoorGuard::Mode::kStale;  // the base moved since: the distance is not trusted
    g.stale_speed_m_s = config_.drive.stale_forward_speed_m_s;
    return g;
  }
  g.mode = DoorGuard::Mode::kStandoff;
  g.line = *line;
  g.standoff_m = config_.drive.approach_min_standoff_m;
  return g;
}

bool EngineImpl::sync_door_guard() {
  const DoorGuard g = door_guard();
  if (g == posted_guard_) return true;
  if (!loop_->post_door_guard(g)) return false;
  posted_guard_ = g;
  return true;
}

Outcome EngineImpl::check_door_guard(const protocol::Drive& m) const {
  if (!(m.linear_m_s > 0) || m.angular_rad_s != 0) return Ok{};  // backing off or turning
  const DoorGuard g = door_guard();
  const core::PlanarPose pose = loop_->snapshot().pose;
  if (!(door_guard_room_m(g, pose) <= 0.001)) return Ok{};
  return make_error(
      ErrorCode::kAtMinimumStandoff, "linear_m_s",
      fmt::format("the base is {:.3f} m from the door, at drive.approach_min_standoff_m "
                  "({:.3f} m): it does not drive closer; back off, turn, or measure "
                  "the door again",
                  procedure_.door(pose).distance_m, g.standoff_m));
}

std::string EngineImpl::door_guard_clause() const {
  const DoorGuard g = door_guard();
  if (g.mode == DoorGuard::Mode::kStale) {
    return fmt::format("; forward at most {:.3f} m/s: stale door plane", g.stale_speed_m_s);
  }
  if (g.mode == DoorGuard::Mode::kStandoff) {
    return fmt::format("; forward stops at {:.3f} m (door {:.3f} m)", g.standoff_m,
                       procedure_.door(loop_->snapshot().pose).distance_m);
  }
  return {};
}

protocol::Message EngineImpl::approach(MessageType type, const protocol::Approach& m) {
  if (auto s = check_base_may_drive(false); !s) return refuse(type, s.error());
  const core::DriveLimits& limits = config_.drive;
  if (!(m.standoff_m >= limits.approach_min_standoff_m)) {
    return refuse(
        type, make_error(
                  ErrorCode::kStandoffOutOfRange, "standoff_m",
                  fmt::format("standoff {:.3f} m is below drive.approach_min_standoff_m ({:.3f} m)",
                              m.standoff_m, limits.approach_min_standoff_m)));
  }
  const core::PlanarPose pose = loop_->snapshot().pose;
  if (procedure_.plane()) {
    if (auto s = procedure_.plane_fresh(); !s) return refuse(type, s.error());
  }
  const protocol::DoorRelation door = procedure_.door(pose);
  if (!door.has_distance) {
    return refuse(type, make_error(ErrorCode::kNoDoorDistance, "",
                                   "no distance to the door is known: measure the door width "
                                   "(or the door plane) first"));
  }
  if (std::abs(door.yaw_rad) > limits.approach_square_tolerance_rad) {
    return refuse(type,
                  make_error(ErrorCode::kNotSquareToDoor, "door.yaw_rad",
                             fmt::format("the base is {:.3f} rad off square to the door (tolerance "
                                         "{:.3f} rad): align or jog square first",
                                         door.yaw_rad, limits.approach_square_tolerance_rad)));
  }
  protocol::ApproachAck body;
  body.start_distance_m = door.distance_m;
  body.travel_m = door.distance_m - m.standoff_m;
  if (std::abs(body.travel_m) > limits.approach_max_travel_m) {
    return refuse(type,
                  make_error(ErrorCode::kApproachTooFar, "standoff_m",
                             fmt::format("the approach would travel {:.3f} m, more than "
                                         "drive.approach_max_travel_m ({:.3f} m): jog closer first",
                                         body.travel_m, limits.approach_max_travel_m)));
  }
  const core::StraightCommand wheels = core::straight_command(body.travel_m, config_.base);
  body.left_counts = wheels.left_counts;
  body.right_counts = wheels.right_counts;
  if (wheels.left_counts == 0 && wheels.right_counts == 0) return ack(type, body);  // there
  loop_->heartbeat(now_ns());
  const MoveCommand move{motion_id_ + 1, wheels.left_counts, wheels.right_counts,
                         MoveProfile::kStraight};
  if (!hand_over(move)) return refuse(type, queue_full());
  ++motion_id_;
  begin_wheel_motion(move.motion_id, WheelKind::kApproach);
  emit(EventKind::kMotionStarted, ErrorCode::kOk,
       fmt::format("approaching: {:.3f} m to {:.3f} m from the door (left {} counts, right {} "
                   "counts)",
                   body.travel_m, m.standoff_m, move.left_counts, move.right_counts));
  return ack(type, body);
}

bool EngineImpl::hand_over(const MoveCommand& move) {
  if (!in_read_batch_) return loop_->post_move(move);
  held_move_ = move;
  return true;
}

bool EngineImpl::hand_over(const DriveCommand& drive) {
  if (!in_read_batch_) return loop_->post_drive(drive);
  held_drive_ = drive;
  return true;
}

Error EngineImpl::queue_full() {
  return make_error(ErrorCode::kQueueFull, "", "control loop command queue full: retry later");
}

Outcome EngineImpl::check_base_may_drive(bool jog) {
  if (procedure_.fault() != ErrorCode::kOk) {
    return make_error(
        ErrorCode::kFaultLatched, "",
        "a fault is latched (" + std::string(to_string(procedure_.fault())) + "): Reset first");
  }
  const Phase phase = procedure_.phase();
  if (phase == Phase::kAligning) {
    return make_error(ErrorCode::kMotionInProgress, "",
                      "the base is aligning: wait for motion_finished, or Stop");
  }
  if (phase == Phase::kEngaging || phase == Phase::kEngaged) {
    return make_error(ErrorCode::kDriveNotAllowed, "",
                      "the arm is at the door (engaging or engaged): the base must not move; "
                      "re-measure or Reset first");
  }
  if (auto s = check_arm_clear(); !s) return s;
  if (wheel_motion_ == 0) return Ok{};
  if (wheel_stopping_) {
    return make_error(ErrorCode::kDriveNotAllowed, "",
                      "the wheels are still stopping: wait for motion_stopped");
  }
  if (wheel_kind_ == WheelKind::kApproach) {
    return make_error(ErrorCode::kMotionInProgress, "",
                      "an approach is running: wait for motion_finished, or Stop");
  }
  if (jog) return Ok{};  // updates the running jog
  return make_error(ErrorCode::kMotionInProgress, "",
                    "the base is being driven: release the drive keys (or Stop) and wait for "
                    "motion_finished");
}

Outcome EngineImpl::check_wheels_stopped() const {
  if (wheel_motion_ == 0) return Ok{};
  return make_error(ErrorCode::kMotionInProgress, "",
                    "the wheels are still stopping: wait for them to rest");
}

void EngineImpl::begin_wheel_motion(std::uint32_t id, WheelKind kind) {
  wheel_motion_ = id;
  wheel_kind_ = kind;
  wheel_stopping_ = false;
}

Outcome EngineImpl::check_wheels_at_rest() const {
  if (wheel_motion_ == 0 || wheel_kind_ == WheelKind::kAlign) return Ok{};
  return make_error(
      ErrorCode::kMotionInProgress, "",
      std::string("the base is moving (") +
          what_moves(wheel_kind_ == WheelKind::kJog, wheel_kind_ == WheelKind::kApproach) +
          "): wait for it to come to rest (motion_finished), or Stop");
}

protocol::Message EngineImpl::engage(MessageType type) {
  auto task = procedure_.check_engage();
  if (!task) return refuse(type, task.error());
  if (auto s = check_wheels_stopped(); !s) return refuse(type, s.error());
  if (now_ns() < loop_->snapshot().rest_not_before_ns) {  // a card's status can lag a stop
    return refuse(type, make_error(ErrorCode::kMotionInProgress, "",
                                   "the wheels may still be coming to rest after the stop (the "
                                   "card's stop time): Engage again in a moment"));
  }
  auto id = arm_->hand_off(*task);
  if (!id) {
    Error e = id.error();
    if (e.field.empty()) e.field = "arm";
    return refuse(type, e);
  }
  arm_task_id_ = *id;
  arm_motion_ = true;
  arm_at_door_ = true;  // until it reports idle after this task
  loop_->set_arm_at_door(true);
  // A driver shows the task busy at once (the mock, the serial driver's snapshot): a controller
  // that drops it before the first poll is caught too.
  arm_seen_busy_ = arm_->status().phase == drivers::ArmPhase::kBusy;
  arm_deadline_ns_ = now_ns() + static_cast<std::int64_t>(config_.safety.arm_task_timeout_s * 1e9);
  loop_->heartbeat(now_ns());
  loop_->set_arm_moving(true);
  procedure_.engaging_started();
  emit(EventKind::kMotionStarted, ErrorCode::kOk,
       "engaging: task " + std::to_string(arm_task_id_) + " handed to the arm");
  dirty_ = true;
  return ack(type, protocol::EmptyAck{});
}

void EngineImpl::stop_motion() {
  cancel_held_move(ErrorCode::kOk);
  if (wheel_motion_ != 0) wheel_stopping_ = true;
  loop_->request_stop();
  stop_arm();
  loop_->set_arm_moving(false);
  if (procedure_.phase() == Phase::kAligning) procedure_.alignment_interrupted();
  if (procedure_.phase() == Phase::kEngaging) procedure_.engaging_interrupted();
  end_arm_motion(
      EventKind::kMotionStopped,
      arm_stop_pending_ ? "arm told to stop: the base waits until it reports idle" : "arm stopped");
  dirty_ = true;
}

protocol::Message EngineImpl::stop(MessageType type) {
  stop_motion();
  return ack(type, protocol::EmptyAck{});
}

protocol::Message EngineImpl::emergency_stop(MessageType type) {
  cancel_held_move(ErrorCode::kEmergencyStopped);
  if (wheel_motion_ != 0) wheel_stopping_ = true;
  loop_->request_emergency_stop();
  stop_arm();
  latch(ErrorCode::kEmergencyStopped, "emergency stop: wheels and arm stopped");
  return ack(type, protocol::EmptyAck{});
}

protocol::Message EngineImpl::reset(MessageType type, const protocol::Reset& r) {
  if (supervisor_->stalled()) {  // the card call that hung has not returned: nothing to recover yet
    return refuse(type, make_error(ErrorCode::kLoopStalled, "",
                                   "the control loop is still stalled (a motion-card call has "
                                   "not returned): Reset once it runs again"));
  }
  if (procedure_.phase() == Phase::kAligning || procedure_.phase() == Phase::kEngaging ||
      (wheel_motion_ != 0 && !wheel_stopping_) || held_move_ || held_drive_) {
    stop_motion();  // also a jog or an approach
  } else if (arm_at_door_) {
    stop_arm();  // e.g. a done task (the next door): the arm returns to rest
  }
  if (procedure_.fault() != ErrorCode::kOk) {
    if (auto s = recover_arm(); !s) {
      Error e = s.error();
      if (e.field.empty()) e.field = "arm";
      return refuse(type, e);
    }
    // The arm interlock: the fault clears only once the arm answers, reporting idle.
    const drivers::ArmStatus arm = observe_arm();
    if (arm_at_door_ || arm.phase != drivers::ArmPhase::kIdle ||
        arm_->state() != drivers::LifecycleState::kActive) {
      return refuse(type, make_error(ErrorCode::kArmNotClear, "arm",
                                     "the arm has not reported idle (" + describe_arm(arm) +
                                         "): it may still be at the door, the fault stays "
                                         "latched; Reset again once it reports idle"));
    }
    if (!loop_->request_recover(recover_sequence_ + 1)) return refuse(type, queue_full());
    ++recover_sequence_;
    const ErrorCode was = procedure_.fault();
    procedure_.clear_fault();
    emit(EventKind::kFaultCleared, ErrorCode::kOk,
         "reset: " + std::string(to_string(was)) + " cleared");
  }
  if (r.clear_parameters) procedure_.clear_parameters();
  dirty_ = true;
  return ack(type, protocol::EmptyAck{});
}

drivers::ArmStatus EngineImpl::observe_arm() {
  const drivers::ArmStatus st = arm_->status();
  const bool idle =
      st.phase == drivers::ArmPhase::kIdle && arm_->state() == drivers::LifecycleState::kActive;
  if (idle && !arm_motion_) {
    arm_at_door_ = false;
    arm_stop_pending_ = false;
  }
  loop_->set_arm_at_door(arm_at_door_ || !idle);
  return st;
}

Outcome EngineImpl::check_arm_clear() {
  const drivers::ArmStatus st = observe_arm();
  if (!arm_at_door_ && st.phase == drivers::ArmPhase::kIdle &&
      arm_->state() == drivers::LifecycleState::kActive) {
    return Ok{};
  }
  std::string what;
  switch (st.phase) {
    case drivers::ArmPhase::kBusy:
      what = arm_stop_pending_ ? ": its stop is not confirmed yet, wait for it to report idle"
                               : ": wait for it to report idle, or Stop";
      break;
    case drivers::ArmPhase::kDone:
      what = ": its task is done but it has not withdrawn; Stop sends it back to rest";
      break;
    case drivers::ArmPhase::kIdle:  // the driver is not active
      what = ": Reset";
      break;
    case drivers::ArmPhase::kDisconnected:
    case drivers::ArmPhase::kFault:
      what = ": check the arm and its link; Reset once it reports idle";
      break;
  }
  return make_error(ErrorCode::kDriveNotAllowed, "arm",
                    "the arm has not reported that it is clear of the door since its last task "
                    "(arm " +
                        describe_arm(st) + ")" + what + "; the base must not move");
}

void EngineImpl::stop_arm() {
  (void)arm_->stop();  // a refusal (link down) is no confirmation either: the deadline decides
  const drivers::ArmStatus st = observe_arm();
  const bool idle =
      st.phase == drivers::ArmPhase::kIdle && arm_->state() == drivers::LifecycleState::kActive;
  if (arm_at_door_ && !idle && !arm_stop_pending_ && procedure_.fault() == ErrorCode::kOk) {
    arm_stop_pending_ = true;
    arm_stop_deadline_ns_ =
        now_ns() + static_cast<std::int64_t>(config_.safety.arm_stop_timeout_s * 1e9);
  }
}

std::string EngineImpl::describe_arm(const drivers::ArmStatus& st) const {
  std::string s(protocol::to_string(to_wire(st.phase)));
  if (st.last_error != ErrorCode::kOk) s += " (" + std::string(to_string(st.last_error)) + ")";
  if (arm_->state() != drivers::LifecycleState::kActive) {
    s += std::string(", driver ") + drivers::to_string(arm_->state());
  }
  return s;
}

Outcome EngineImpl::recover_arm() {
  if (arm_->state() == drivers::LifecycleState::kFault) {
    if (auto s = arm_->recover(); !s) return s;
  }
  if (arm_->state() == drivers::LifecycleState::kInactive) {
    if (auto s = arm_->activate(); !s) return s;
  }
  if (arm_->status().phase == drivers::ArmPhase::kFault) {
    if (auto s = arm_->clear_fault(); !s) return s;
  }
  return Ok{};
}

}  // namespace ajar::daemon::detail
