// The interleaving world's arm controller faults and the arm interlock (world.hpp;
// docs/procedure.md, "The arm interlock"): the controller stops answering mid-task or at a stop,
// resets mid-task, answers stops but stays busy, answers again. The invariant, checked every cycle
// and after every read: the base never moves while the arm may be at the door — no move and no jog
// with a speed reaches the card, the simulated wheels do not turn.
#include "world.hpp"

namespace ajar::testing::interleaving {

void World::inject_arm_fault() {
  const auto phase = arm_->status().phase;
  const bool stuck = arm_->silent() || phase == drivers::ArmPhase::kDisconnected;
  const bool busy = phase == drivers::ArmPhase::kBusy && !stuck;
  int what = pick(6);
  if (stuck ? what >= 2 : busy && what >= 4) return arm_clears_up();
  what %= 4;
  if (!busy) {  // for the next tasks, by time (the config's words: drivers.mock.arm_fault)
    static constexpr drivers::MockArmFault kNext[] = {
        drivers::MockArmFault::kSilentMidTask, drivers::MockArmFault::kSilentMidStop,
        drivers::MockArmFault::kResetMidTask, drivers::MockArmFault::kStopIgnored};
    static constexpr const char* kWords[] = {"silent_mid_task", "silent_mid_stop", "reset_mid_task",
                                             "stop_ignored"};
    note(std::string("arm: the next task under ") + kWords[what]);
    arm_->set_fault(kNext[what]);
    arm_silence_on_stop_ = kNext[what] == drivers::MockArmFault::kSilentMidStop;
    return;
  }
  switch (what) {
    case 0:
      note("arm: the controller stops answering mid-task");
      arm_->go_silent();
      break;
    case 1:
      note("arm: the controller will not answer the next stop");
      arm_->silence_next_stop();
      arm_silence_on_stop_ = true;
      break;
    case 2:
      note("arm: the controller resets mid-task (idle, the task forgotten)");
      arm_->reset_controller();
      return;
    default:
      note("arm: the controller answers stops but stays busy");
      arm_->ignore_stops(true);
      break;
  }
  // Often the operator stops it then (the reported case: Engage, the arm falls silent, Stop).
  if (controller_ != nullptr && pick(2) == 0) {
    read(*controller_, {protocol::Message{protocol::Stop{}}});
  }
}

void World::arm_clears_up() {
  if (arm_->silent()) note("arm: the controller answers again");
  arm_->set_fault(drivers::MockArmFault::kNone);   // answers again (a stop it owes acts), no faults
  arm_->set_fault(drivers::MockArmFault::kStuck);  // tasks end when the scenario says
  arm_silence_on_stop_ = false;
  if (arm_->status().phase == drivers::ArmPhase::kDisconnected) {
    note("arm: its link is back (idle)");
    arm_->set_phase(drivers::ArmPhase::kIdle);
  }
}

void World::observe_arm() {
  const drivers::ArmStatus st = arm_->status();
  const bool silent = arm_->silent();
  if (arm_->tasks_started() != arm_tasks_seen_) {
    arm_tasks_seen_ = arm_->tasks_started();
    arm_at_door_ = true;
  } else if (arm_last_phase_ == drivers::ArmPhase::kBusy && st.phase == drivers::ArmPhase::kIdle &&
             st.task_id == 0) {
    coverage_.bump("arm reset mid-task");
  }
  if (silent && !arm_was_silent_) {
    coverage_.bump(arm_silence_on_stop_ ? "arm silent mid-stop" : "arm silent mid-task");
    arm_silence_on_stop_ = false;
  }
  if (arm_->stops() != arm_stops_seen_ && !silent && st.phase == drivers::ArmPhase::kBusy) {
    coverage_.bump("arm stop ignored");
  }
  arm_stops_seen_ = arm_->stops();
  arm_was_silent_ = silent;
  arm_last_phase_ = st.phase;
  if (st.phase == drivers::ArmPhase::kIdle) arm_at_door_ = false;
}

void World::check_arm_interlock() {
  if (!violation_.empty()) return;
  // What reached the card since the last check, against what the arm had said before it.
  const std::size_t end = card_->log_size();
  if (arm_at_door_) {
    for (const auto& c : card_->log_from(arm_log_seen_)) {
      if (c.kind == CardCall::kMoveRelative || (c.kind == CardCall::kJog && c.jogs())) {
        arm_log_seen_ = end;
        return fail("a wheel motion reached the card while the arm may be at the door");
      }
    }
    if (card_->any_moving()) {
      arm_log_seen_ = end;
      return fail("the wheels turn while the arm may be at the door");
    }
    coverage_.bump("cycles with the arm at the door");
  }
  arm_log_seen_ = end;
  observe_arm();
}

void World::check_arm_on_executed(const protocol::Message& m, const protocol::Message& reply) {
  const bool wheels = std::holds_alternative<protocol::Drive>(m) ||
                      std::holds_alternative<protocol::Approach>(m) ||
                      std::holds_alternative<protocol::AlignBase>(m);
  if (!wheels) return;
  if (const auto* e = std::get_if<protocol::ErrorReply>(&reply)) {
    if (e->code == ErrorCode::kDriveNotAllowed && e->field.view() == "arm") {
      coverage_.bump("wheel motion refused: the arm not clear");
    }
    return;
  }
  const auto* ack = std::get_if<protocol::Ack>(&reply);
  if (ack == nullptr) return;
  observe_arm();  // a stop earlier in this read may have brought the arm back to rest
  if (!arm_at_door_) return;
  // Acknowledged without motion: a zero Drive with no jog, an Approach of zero counts, an
  // alignment of zero counts.
  if (const auto* d = std::get_if<protocol::Drive>(&m)) {
    if (d->linear_m_s == 0 && d->angular_rad_s == 0 && open_kind_ != 'd') return;
  }
  if (const auto* body = std::get_if<protocol::ApproachAck>(&ack->body)) {
    if (body->left_counts == 0 && body->right_counts == 0) return;
  }
  if (std::holds_alternative<protocol::AlignBase>(m) && ack->state != ProcedureState::kAligning) {
    return;
  }
  fail(std::string(protocol::to_string(protocol::type_of(m))) +
       " accepted while the arm may be at the door (it has not reported idle since its task)");
}

bool World::reset_refused_by_the_arm(const protocol::Message& reply,
                                     const protocol::Status& before) {
  const auto* e = std::get_if<protocol::ErrorReply>(&reply);
  if (e == nullptr || e->field.view() != "arm" || before.latched_fault == ErrorCode::kOk) {
    return false;
  }
  if (arm_->status().phase == drivers::ArmPhase::kIdle && !arm_->silent()) return false;
  coverage_.bump("Reset refused: the arm not clear");
  return true;
}

}  // namespace ajar::testing::interleaving
