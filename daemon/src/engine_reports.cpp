// The engine's side of what happens: the control loop's reports closing wheel motions, the arm's
// task, fault latching, events to the sessions, and the state file (persist and restore).
#include "engine_impl.hpp"

namespace ajar::daemon::detail {

void EngineImpl::drain_reports() {
  take_stall();
  const LoopSnapshot snap = loop_->snapshot();
  if (snap.unstopped != unstopped_told_) {  // the journal says so, once per episode
    unstopped_told_ = snap.unstopped;
    warnings_.push_back(snap.unstopped
                            ? "the wheels still turn after an emergency stop the motion card "
                              "accepted: their servos are being switched off (the card does not "
                              "apply its stops; use the robot's hardware emergency stop)"
                            : "the wheels are at rest again after their servos were switched off");
  }
  if (procedure_.observe_pose(snap.pose)) dirty_ = true;
  LoopReport r;
  while (loop_->pop_report(r)) {
    switch (r.kind) {
      case LoopReportKind::kMotionFinished: {
        const std::optional<WheelKind> kind = wheels_.close(r.motion_id);
        if (!kind) break;
        if (procedure_.phase() == Phase::kAligning) {
          procedure_.alignment_finished();
          dirty_ = true;
        }
        std::string detail = "base aligned";
        if (*kind == WheelKind::kApproach) {
          const auto door = procedure_.door(snap.pose);
          detail = fmt::format("approach finished: the door is {:.3f} m away", door.distance_m);
        } else if (*kind == WheelKind::kJog) {
          detail = r.command_timeout
                       ? "driving ended: no Drive command within drive.command_timeout_s "
                         "(the base decelerated to rest)"
                       : "driving ended: the base is at rest";
        }
        emit(EventKind::kMotionFinished, ErrorCode::kOk, detail);
        break;
      }
      case LoopReportKind::kMotionStopped:
        if (!wheels_.close(r.motion_id)) break;
        if (procedure_.phase() == Phase::kAligning) {  // stopped on its own (should not happen)
          procedure_.alignment_interrupted();
          dirty_ = true;
        }
        emit(EventKind::kMotionStopped, r.code, "wheels stopped" + reason(r.code));
        break;
      case LoopReportKind::kMoveRefused:
      case LoopReportKind::kMoveCancelled:
        close_unstarted_move(r.motion_id, r.code, r.kind == LoopReportKind::kMoveCancelled);
        break;
      case LoopReportKind::kFault:
        if (r.sequence != recover_sequence_) {
          // Latched before the loop took our last Reset's recovery, which clears it (and
          // fails, latching again, if the cause persists). Not lost: the journal has it.
          warnings_.push_back("control loop fault " + std::string(to_string(r.code)) +
                              " before the Reset's recovery ran: that recovery clears it");
          break;
        }
        latch(r.code, r.axis != 0 ? "axis " + std::to_string(r.axis) : std::string("control loop"));
        break;
      case LoopReportKind::kRecovered:
        if (r.sequence != recover_sequence_) break;  // an earlier Reset's recovery
        if (r.code != ErrorCode::kOk) latch(r.code, "the motion card did not recover");
        break;
    }
  }
}

void EngineImpl::close_unstarted_move(std::uint32_t motion_id, ErrorCode code, bool cancelled) {
  const std::optional<WheelKind> kind = wheels_.close(motion_id);
  if (!kind) return;
  if (*kind == WheelKind::kAlign) {
    procedure_.alignment_not_started();  // also after a stop interrupted it: nothing turned
  }
  dirty_ = true;
  emit(EventKind::kMotionStopped, code,
       (cancelled ? "the move was cancelled before it started" : "the move did not start") +
           reason(code));
}

void EngineImpl::cancel_held_move(ErrorCode code) {
  wheels_.cancel_held(
      [this, code](std::uint32_t motion_id) { close_unstarted_move(motion_id, code, true); });
}

std::string EngineImpl::reason(ErrorCode code) const {
  if (!stop_reason_.empty()) return ": " + stop_reason_;
  return code == ErrorCode::kOk ? std::string() : ": " + std::string(to_string(code));
}

void EngineImpl::supervise_arm() {
  const ArmVerdict stop = arm_.supervise_stop(now_ns());
  if (stop.kind == ArmVerdict::Kind::kFault) latch(stop.code, stop.detail);
  const ArmVerdict task = arm_.supervise_task(now_ns());
  if (task.kind == ArmVerdict::Kind::kTaskDone) {
    procedure_.engaging_finished();
    end_arm_motion(EventKind::kMotionFinished, "the arm finished the door task");
    dirty_ = true;
  } else if (task.kind == ArmVerdict::Kind::kFault) {
    latch(task.code, task.detail);
  }
}

void EngineImpl::end_arm_motion(EventKind kind, const std::string& detail) {
  if (arm_.end_task()) emit(kind, ErrorCode::kOk, detail);
}

void EngineImpl::reconcile() {
  const LoopSnapshot snap = loop_->snapshot();
  if (snap.reports_dropped == 0) return;
  if (snap.recover_sequence == recover_sequence_ && !snap.recovering &&
      snap.fault != ErrorCode::kOk) {
    latch(snap.fault, "control loop");
  }
  if (!snap.motion_active && wheels_.close(snap.last_motion_id)) {
    if (procedure_.phase() == Phase::kAligning) procedure_.alignment_interrupted();
    dirty_ = true;
    emit(EventKind::kMotionStopped, ErrorCode::kOk, "wheels at rest");
  }
}

void EngineImpl::take_stall() {
  const LoopSupervisor::Stall stall = supervisor_->last_stall();
  if (stall.count != stalls_seen_) {
    stalls_seen_ = stall.count;
    latch(ErrorCode::kLoopStalled,
          fmt::format("no control-loop cycle for {:.0f} ms (a card call hung): base "
                      "emergency-stopped out of band",
                      static_cast<double>(stall.silent_ns) / 1e6));
    // The journal only (the detail above fills the wire's 120 bytes): what was excused.
    warnings_.push_back(fmt::format(
        "loop supervisor: the control thread made no cycle for {:.0f} ms, {:.0f} ms of it waiting "
        "for a CPU (excused: the scheduler's, not the card's); stall timeout {:.0f} ms",
        static_cast<double>(stall.silent_ns) / 1e6, static_cast<double>(stall.excused_ns) / 1e6,
        static_cast<double>(supervisor_->stall_timeout_ns()) / 1e6));
  }
  if (stall.stops != stall_stops_seen_) {
    stall_stops_seen_ = stall.stops;
    warnings_.push_back(
        stall.stop_result == ErrorCode::kOk
            ? std::string("loop supervisor: out-of-band emergency stop taken by the card")
            : "loop supervisor: out-of-band emergency stop refused by the card: " +
                  std::string(to_string(stall.stop_result)) +
                  " (the base may move until the hung call returns or systemd's watchdog "
                  "restarts ajard; docs/drivers.md, \"Stopping a stalled loop\")");
  }
}

void EngineImpl::latch(ErrorCode code, const std::string& detail) {
  const bool was_clear = procedure_.fault() == ErrorCode::kOk;
  wheels_.stopping_asked();  // the loop stops the wheels for a fault
  procedure_.latch_fault(code);
  stop_arm();  // whatever latched, the arm does not go on
  if (arm_.task_open()) {
    end_arm_motion(EventKind::kMotionStopped,
                   "arm stopped: " + std::string(to_string(code)) + ": " + detail);
  }
  loop_->set_arm_moving(false);
  if (was_clear) {
    const std::string text = std::string(to_string(code)) + ": " + detail;
    emit(EventKind::kFaultLatched, code, text);
    warnings_.push_back("fault latched: " + text);
  }
  dirty_ = true;
}

void EngineImpl::emit(EventKind kind, ErrorCode fault, const std::string& detail) {
  protocol::Event e;
  e.kind = kind;
  e.state = procedure_.state();
  e.fault = kind == EventKind::kFaultLatched ? fault : ErrorCode::kOk;
  e.daemon_time_ns = daemon_time_ns();
  e.detail.assign(detail);
  e.base_motion = base_motion();
  if (sink_) sink_(e);
}

void EngineImpl::flush() {
  if (dirty_) {
    dirty_ = false;
    persist();
  }
  const ProcedureState now = procedure_.state();
  if (now != last_state_) {
    last_state_ = now;
    emit(EventKind::kStateChanged, procedure_.fault(), std::string(protocol::to_string(now)));
  }
}

void EngineImpl::persist() {
  if (!started_) return;
  store_.submit(StateRecord{procedure_.record(), sealed_});
}

void EngineImpl::restore() {
  auto loaded = store_.load();
  if (!loaded) {
    reject_state_file("state file rejected: " + loaded.error().message);
    latch_at_start(ErrorCode::kStateRejected,
                   "the state file could not be read or decoded: its measurements, a fault it "
                   "held and how the last run ended are unknown; measure again");
    return;
  }
  if (!loaded->found) return;  // a first start (or the operator removed the file)
  const StateRecord& file = loaded->record;
  bool rejected = false;
  if (auto s = procedure_.restore(file.procedure); !s) {
    reject_state_file("state file " + store_.path() +
                      " rejected: it no longer validates with this config, starting without its "
                      "measurements: " +
                      describe(s.error()));
    rejected = true;
    if (file.procedure.fault != ErrorCode::kOk) {
      latch_at_start(file.procedure.fault,
                     "latched before the restart, kept from the rejected file");
    }
  } else {
    restored_ = true;
  }
  if (!file.clean_shutdown) {
    latch_at_start(ErrorCode::kUncleanShutdown,
                   file.format_version < 2
                       ? "the state file was written by an older ajard, which recorded no clean "
                         "shutdown: whether the last run ended cleanly is unknown"
                       : "the previous run did not end with a clean shutdown (crash, kill, "
                         "watchdog abort, power loss): a stop acknowledged just before it may "
                         "not have been recorded");
  }
  if (rejected) {
    latch_at_start(ErrorCode::kStateRejected,
                   "the stored measurements no longer validate with this config; measure again");
  }
}

void EngineImpl::latch_at_start(ErrorCode code, const std::string& why) {
  const ErrorCode before = procedure_.fault();
  procedure_.latch_fault(code);
  const std::string what = std::string(to_string(code)) + ": " + why;
  startup_warnings_.push_back(
      before == ErrorCode::kOk
          ? "fault latched at start: " + what + "; check the robot, then Reset"
          : what + " (" + std::string(to_string(before)) + " stays latched: Reset after checking)");
}

void EngineImpl::reject_state_file(std::string warning) {
  startup_warnings_.push_back(std::move(warning));
  if (!std::filesystem::exists(store_.path())) return;
  auto kept = store_.reject_current_file();
  startup_warnings_.push_back(kept ? "kept the rejected state file as " + *kept
                                   : "could not keep the rejected state file: " +
                                         kept.error().message);
}

}  // namespace ajar::daemon::detail
