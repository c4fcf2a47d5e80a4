// The engine's commands: every request the procedure answers, the motions it hands to the
// control loop (align, drive, approach), engage, the stops and reset.
#include "engine_impl.hpp"

#include "ajar/protocol/message_table.hpp"

namespace ajar::daemon::detail {

namespace {
namespace rf = protocol::refusal_field;

// std::visit over the request: one lambda per message type it answers.
template <typename... F>
struct Overloaded : F... {
  using F::operator()...;
};
template <typename... F>
Overloaded(F...) -> Overloaded<F...>;
}  // namespace

protocol::Message EngineImpl::dispatch(const protocol::Message& request) {
  const MessageType type = protocol::type_of(request);
  if (protocol::policy_of(type).needs_wheels_at_rest && procedure_.fault() == ErrorCode::kOk) {
    if (auto s = wheels_.check_at_rest(); !s) return refuse(type, s.error());
  }
  return std::visit(Overloaded{
                        [&](const protocol::MeasureDoorWidth& m) {
                          return answer(type, procedure_.measure_width(m));
                        },
                        [&](const protocol::MeasureHandle& m) {
                          return answer(type, procedure_.measure_handle(m));
                        },
                        [&](const protocol::MeasureDoorPlane& m) {
                          return answer(type, procedure_.measure_plane(m));
                        },
                        [&](const protocol::SetContactPoint& m) {
                          return answer(type, procedure_.set_contact(m));
                        },
                        [&](const protocol::AlignBase&) { return align(type); },
                        [&](const protocol::Engage&) { return engage(type); },
                        [&](const protocol::Stop&) { return stop(type); },
                        [&](const protocol::EmergencyStop&) { return emergency_stop(type); },
                        [&](const protocol::Reset& m) { return reset(type, m); },
                        [&](const protocol::Drive& m) { return drive(type, m); },
                        [&](const protocol::Approach& m) { return approach(type, m); },
                        [&](const protocol::ResetLoopStatistics&) {
                          loop_->statistics().reset(monotonic_now_ns());
                          return ack(type, protocol::EmptyAck{});
                        },
                        [&](const auto&) {
                          return refuse(type, make_error(ErrorCode::kWrongState, "",
                                                         "not a command for the procedure"));
                        },
                    },
                    request);
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
  if (auto s = wheels_.check_stopped(); !s) return refuse(type, s.error());
  if (wheels->left_counts == 0 && wheels->right_counts == 0) {  // already square to the door
    procedure_.alignment_started();
    procedure_.alignment_finished();
    dirty_ = true;
    // An accepted motion of zero counts is still opened and closed by events (protocol.md 5.7).
    emit(EventKind::kMotionStarted, ErrorCode::kOk,
         "aligning: left 0 counts, right 0 counts (already square to the door)");
    emit(EventKind::kMotionFinished, ErrorCode::kOk, "base aligned (nothing to turn)");
    return ack(type, protocol::EmptyAck{});
  }
  if (auto s = arm_.check_clear(); !s) return refuse(type, s.error());
  loop_->heartbeat(now_ns());  // the controller just spoke
  if (!wheels_.start_move(wheels->left_counts, wheels->right_counts, MoveProfile::kTurn,
                          WheelKind::kAlign)) {
    return refuse(type, queue_full());
  }
  procedure_.alignment_started();
  emit(EventKind::kMotionStarted, ErrorCode::kOk,
       "aligning: left " + std::to_string(wheels->left_counts) + " counts, right " +
           std::to_string(wheels->right_counts) + " counts");
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
  if (wheels_.current() != 0) {  // a running jog: update it
    if (!wheels_.update_jog(velocity, stamp)) return refuse(type, queue_full());
    return ack(type, protocol::EmptyAck{});
  }
  if (velocity.linear_m_s == 0 && velocity.angular_rad_s == 0) {
    return ack(type, protocol::EmptyAck{});  // at rest already: nothing to do
  }
  if (!wheels_.start_jog(velocity, stamp)) return refuse(type, queue_full());
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

Outcome EngineImpl::check_door_guard(const protocol::Drive& m) const {
  if (!(m.linear_m_s > 0) || m.angular_rad_s != 0) return Ok{};  // backing off or turning
  const DoorGuard g = door_guard();
  const core::PlanarPose pose = loop_->snapshot().pose;
  if (!(door_guard_room_m(g, pose) <= 0.001)) return Ok{};
  return make_error(
      ErrorCode::kAtMinimumStandoff, std::string(rf::kLinear),
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
                  ErrorCode::kStandoffOutOfRange, std::string(rf::kStandoff),
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
                  make_error(ErrorCode::kNotSquareToDoor, std::string(rf::kDoorYaw),
                             fmt::format("the base is {:.3f} rad off square to the door (tolerance "
                                         "{:.3f} rad): align or jog square first",
                                         door.yaw_rad, limits.approach_square_tolerance_rad)));
  }
  protocol::ApproachAck body;
  body.start_distance_m = door.distance_m;
  body.travel_m = door.distance_m - m.standoff_m;
  if (std::abs(body.travel_m) > limits.approach_max_travel_m) {
    return refuse(type,
                  make_error(ErrorCode::kApproachTooFar, std::string(rf::kStandoff),
                             fmt::format("the approach would travel {:.3f} m, more than "
                                         "drive.approach_max_travel_m ({:.3f} m): jog closer first",
                                         body.travel_m, limits.approach_max_travel_m)));
  }
  const core::StraightCommand wheels = core::straight_command(body.travel_m, config_.base);
  body.left_counts = wheels.left_counts;
  body.right_counts = wheels.right_counts;
  if (wheels.left_counts == 0 && wheels.right_counts == 0) {  // there already: nothing moves
    emit(EventKind::kMotionStarted, ErrorCode::kOk,
         fmt::format("approaching: {:.3f} m to {:.3f} m from the door (left 0 counts, right 0 "
                     "counts)",
                     body.travel_m, m.standoff_m));
    emit(EventKind::kMotionFinished, ErrorCode::kOk,
         fmt::format("approach finished: the door is {:.3f} m away (nothing to drive)",
                     door.distance_m));
    return ack(type, body);
  }
  loop_->heartbeat(now_ns());
  if (!wheels_.start_move(wheels.left_counts, wheels.right_counts, MoveProfile::kStraight,
                          WheelKind::kApproach)) {
    return refuse(type, queue_full());
  }
  emit(EventKind::kMotionStarted, ErrorCode::kOk,
       fmt::format("approaching: {:.3f} m to {:.3f} m from the door (left {} counts, right {} "
                   "counts)",
                   body.travel_m, m.standoff_m, wheels.left_counts, wheels.right_counts));
  return ack(type, body);
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
  if (auto s = arm_.check_clear(); !s) return s;
  return wheels_.check_may_drive(jog);
}

protocol::Message EngineImpl::engage(MessageType type) {
  auto task = procedure_.check_engage();
  if (!task) return refuse(type, task.error());
  if (auto s = wheels_.check_stopped(); !s) return refuse(type, s.error());
  if (now_ns() < loop_->snapshot().rest_not_before_ns) {  // a card's status can lag a stop
    return refuse(type, make_error(ErrorCode::kMotionInProgress, "",
                                   "the wheels may still be coming to rest after the stop (the "
                                   "card's stop time): Engage again in a moment"));
  }
  loop_->heartbeat(now_ns());  // the controller just spoke (before the loop watches the arm move)
  auto id = arm_.hand_off(*task, now_ns());
  if (!id) {
    Error e = id.error();
    e.field = rf::kArm;  // the arm's refusal (protocol.md 8), whatever the driver's field
    return refuse(type, e);
  }
  procedure_.engaging_started();
  emit(EventKind::kMotionStarted, ErrorCode::kOk,
       "engaging: task " + std::to_string(*id) + " handed to the arm");
  dirty_ = true;
  return ack(type, protocol::EmptyAck{});
}

void EngineImpl::stop_motion() {
  cancel_held_move(ErrorCode::kOk);
  wheels_.stopping_asked();
  loop_->request_stop();
  stop_arm();
  loop_->set_arm_moving(false);
  if (procedure_.phase() == Phase::kAligning) procedure_.alignment_interrupted();
  if (procedure_.phase() == Phase::kEngaging) procedure_.engaging_interrupted();
  end_arm_motion(EventKind::kMotionStopped,
                 arm_.stop_pending() ? "arm told to stop: the base waits until it reports idle"
                                     : "arm stopped");
  dirty_ = true;
}

protocol::Message EngineImpl::stop(MessageType type) {
  stop_motion();
  return ack(type, protocol::EmptyAck{});
}

protocol::Message EngineImpl::emergency_stop(MessageType type) {
  cancel_held_move(ErrorCode::kEmergencyStopped);
  wheels_.stopping_asked();
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
      (wheels_.current() != 0 && !wheels_.stopping()) || wheels_.held()) {
    stop_motion();  // also a jog or an approach
  } else if (arm_.at_door()) {
    stop_arm();  // e.g. a done task (the next door): the arm returns to rest
  }
  if (procedure_.fault() != ErrorCode::kOk && loop_->snapshot().unstopped) {
    // The card took an emergency stop and the wheels still turn: nothing to recover into.
    return refuse(type, make_error(ErrorCode::kMotionInProgress, "",
                                   "the wheels still turn after an emergency stop the motion card "
                                   "accepted (their servos are being switched off): the fault "
                                   "stays latched; use the robot's hardware emergency stop, Reset "
                                   "once they rest"));
  }
  if (procedure_.fault() != ErrorCode::kOk) {
    if (auto s = arm_.recover(); !s) {
      Error e = s.error();
      e.field = rf::kArm;  // the arm's refusal (protocol.md 8), whatever the driver's field
      return refuse(type, e);
    }
    // The arm interlock: the fault clears only once the arm answers, reporting idle.
    const drivers::ArmStatus arm = arm_.observe();
    if (arm_.at_door() || arm.phase != drivers::ArmPhase::kIdle ||
        arm_.state() != drivers::LifecycleState::kActive) {
      return refuse(type, make_error(ErrorCode::kArmNotClear, std::string(rf::kArm),
                                     "the arm has not reported idle (" + arm_.describe(arm) +
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

}  // namespace ajar::daemon::detail
