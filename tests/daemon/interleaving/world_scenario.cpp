// The interleaving world's random scenario: commands, keys, observers, controller loss, card
// faults, arm outcomes, and the final quiescing (world.hpp).
#include "world.hpp"

#include "fake_door.hpp"

namespace ajar::testing::interleaving {

void World::step() {
  int what = pick(100);
  // A calm seed follows the procedure more and disrupts less, so that long motions (an
  // alignment, an approach, the arm's task) also run to their end.
  if (calm_ && what >= 52 && what < 70 && pick(4) != 0) what = 0;
  if (what < 52) {
    if (controller_ != nullptr) {
      const int n = 1 + pick(4);  // several frames in one read
      std::vector<Frame> frames;
      for (int i = 0; i < n; ++i)
        frames.push_back(random_command());
      if (pick(3) != 0) {
        read(*controller_, frames);
      } else {  // or each in its own read, all before the loop's next cycle
        for (const auto& f : frames)
          if (controller_ != nullptr) read(*controller_, std::vector<Frame>{f});
      }
      // An observer's stop racing the controller's commands (before the next cycle).
      if (pick(10) == 0) observer_action();
    }
  } else if (what < 55) {
    observer_action();
  } else if (what < 58) {
    lose_controller();
  } else if (what < 61) {
    alive_ = !alive_;
    note(alive_ ? "controller speaks again" : "controller goes silent");
  } else if (what < 70) {
    if (pick(2) == 0) {
      inject_card_fault();
    } else {
      inject_card_misbehaviour();
    }
  } else if (what < 78) {
    arm_event();
  } else if (what < 84) {
    key_action();
  }
  const int cycles = 1 + pick(what < 90 ? 4 : calm_ ? 300 : 40);
  for (int i = 0; i < cycles && violation_.empty(); ++i)
    cycle(pick(3) != 0);
}

World::Frame World::random_command() {
  if (calm_ && pick(4) != 0) return {next_procedure_step(), false, 0};
  const int what = pick(100);
  if (what < 7 && controller_ != nullptr) {
    if (const auto it = sent_.find(last_request_);
        it != sent_.end() && it->second.link_instance == controller_->instance) {
      return {it->second.message, true, last_request_};
    }
  }
  protocol::Message m;
  if (what < 20) {
    m = next_procedure_step();
  } else if (what < 30) {
    m = protocol::AlignBase{};
  } else if (what < 38) {
    m = protocol::Stop{};
  } else if (what < 42) {
    m = protocol::EmergencyStop{};
  } else if (what < 51) {
    m = protocol::Reset{pick(6) == 0};
  } else if (what < 61) {
    m = plane_at_yaw((pick(2) == 0 ? -1 : 1) * (0.01 + 0.01 * pick(12)));
  } else if (what < 67) {
    m = protocol::Engage{};
  } else if (what < 71) {
    m = good_contact();
  } else if (what < 75) {
    m = good_width();
  } else if (what < 78) {
    m = good_handle();
  } else if (what < 90) {
    m = random_drive();
  } else {
    m = random_approach();
  }
  return {m, false};
}

protocol::Drive World::random_drive() {
  static constexpr double kLinear[] = {0, 0, 0.05, -0.05, 0.1, 0.2, -0.3, 0.5};
  static constexpr double kAngular[] = {0, 0, 0, 0.2, -0.3, 0.6, -1.0};
  return {kLinear[pick(8)], kAngular[pick(7)]};
}

protocol::Approach World::random_approach() {
  const auto st = engine_->status();
  const double distance = st.door.has_distance ? st.door.distance_m : 1.5;
  switch (pick(8)) {
    case 0:
      return {0.1};  // below drive.approach_min_standoff_m
    case 1:
      return {distance - 3.0};  // too far (or below the minimum)
    case 2:
      return {std::nan("")};
    default:  // a short move either way
      return {distance - 0.02 * (pick(7) - 1)};
  }
}

protocol::Message World::next_procedure_step() {
  switch (engine_->status().state) {
    case ProcedureState::kAwaitingWidth:
      return good_width();
    case ProcedureState::kAwaitingHandle:  // the operator drives closer for the handle
      return pick(3) == 0 ? protocol::Message{random_approach()} : protocol::Message{good_handle()};
    case ProcedureState::kAwaitingPlane:
    case ProcedureState::kReadyToAlign:
      return pick(2) == 0 ? protocol::Message{plane_at_yaw(0.05 + 0.01 * pick(8))}
                          : protocol::Message{protocol::AlignBase{}};
    case ProcedureState::kAligned:
      return good_contact();
    case ProcedureState::kReadyToEngage:
      return protocol::Engage{};
    case ProcedureState::kFault:
      return protocol::Reset{false};
    case ProcedureState::kEngaged:
      return protocol::Reset{true};  // done: the next door
    case ProcedureState::kAligning:
    case ProcedureState::kEngaging:
      if (calm_) return protocol::GetStatus{};
      return protocol::Stop{};
    default:
      return protocol::Stop{};
  }
}

void World::key_action() {
  if (controller_ == nullptr) return;
  if (!key_) {
    protocol::Drive d = random_drive();
    if (d.linear_m_s == 0 && d.angular_rad_s == 0) d.linear_m_s = 0.1;
    key_ = d;
    key_every_ = 5 + pick(15);
    note("key pressed");
    read(*controller_, {protocol::Message{*key_}});
    return;
  }
  switch (pick(3)) {
    case 0:
      note("key released");
      key_.reset();
      read(*controller_, {protocol::Message{protocol::Drive{}}});
      break;
    case 1:
      note("the client stops sending Drive (the command timeout must end the jog)");
      key_.reset();
      break;
    default:
      key_ = random_drive();
      note("key changed");
      read(*controller_, {protocol::Message{*key_}});
      break;
  }
}

void World::observer_action() {
  FakeLink* o = observer_;
  for (auto& l : links_)  // a demoted controller speaks as an observer too
    if (l.get() != controller_ && pick(2) == 0) o = l.get();
  if (o == nullptr) return;
  switch (pick(4)) {
    case 0:
      read(*o, {protocol::Message{protocol::Stop{}}});
      break;
    case 1:
      read(*o, {protocol::Message{protocol::EmergencyStop{}}});
      break;
    case 2:
      read(*o,
           {protocol::Message{protocol::Drive{0.2, 0}}, protocol::Message{protocol::AlignBase{}}});
      break;
    default:
      read(*o, {protocol::Message{protocol::Reset{}}, protocol::Message{protocol::GetStatus{}}});
      break;
  }
}

void World::lose_controller() {
  switch (pick(3)) {
    case 0: {
      note("take-over by a second controller session");
      FakeLink* old = controller_;
      controller_ = connect(protocol::Role::kController, true, 0x9000 + tick_);
      if (old != nullptr && pick(2) == 0) disconnect(old, "the old controller leaves");
      coverage_.bump("take-over");
      break;
    }
    case 1:
      if (controller_ == nullptr) break;
      note("controller disconnects");
      disconnect(controller_, "connection reset by peer");
      key_.reset();
      break;
    default: {
      if (controller_ != nullptr) break;
      // The same client reconnects (same client instance) and repeats its last request.
      note("controller reconnects");
      const auto last = sent_.find(last_request_);
      const std::uint64_t instance = last == sent_.end() || last->second.link_instance == 0
                                         ? 0x77
                                         : last->second.link_instance;
      controller_ = connect(protocol::Role::kController, false, instance);
      if (last != sent_.end() && pick(2) == 0) {
        read(*controller_, std::vector<Frame>{{last->second.message, true, last_request_}});
      }
      break;
    }
  }
  check_now();
}

void World::inject_card_fault() {
  const int axis = pick(2) == 0 ? left_axis_ : right_axis_;
  const bool moving = card_->any_moving();
  switch (pick(7)) {
    case 0:
      note("card: drive alarm on axis " + std::to_string(axis));
      card_->inject_alarm(axis);
      card_halted_ = true;
      break;
    case 1:
      note("card: following error on axis " + std::to_string(axis));
      card_->inject_following_error(axis);
      card_halted_ = true;
      break;
    case 2:
      note("card: limit on axis " + std::to_string(axis));
      card_->inject_limit(axis, true);
      card_halted_ = true;
      break;
    case 3: {
      const int n = 1 + pick(8);
      card_->fail_next_calls(n);
      note("card: not answering for " + std::to_string(n) + " calls");
      break;
    }
    case 4:
      note("card: refuses the next move");
      card_->refuse_next_move();
      return;
    case 5:
      note("card: the next move never progresses");
      card_->stick_next_move();
      stuck_move_pending_ = true;  // on a wheel still moving: the mock halts it (check_wheels)
      return;
    default:
      stops_never_rest_ = !stops_never_rest_;
      card_->set_stops_never_rest(stops_never_rest_);
      note(std::string("card: smooth stops ") + (stops_never_rest_ ? "never rest" : "rest again"));
      return;
  }
  if (moving) coverage_.bump("card fault mid-motion");
}

void World::arm_event() {
  if (pick(calm_ ? 4 : 2) == 0 || arm_->status().phase != drivers::ArmPhase::kBusy) {
    return inject_arm_fault();  // world_arm.cpp (when idle: for the next task)
  }
  const auto st = arm_->status();
  if (st.phase != drivers::ArmPhase::kBusy) return;
  switch (calm_ && pick(2) == 0 ? 0 : pick(4)) {  // calm: the task mostly succeeds
    case 0:
      note("arm: task done");
      arm_->set_phase(drivers::ArmPhase::kDone);
      break;
    case 1:
      note("arm: fault");
      arm_->set_phase(drivers::ArmPhase::kFault, ErrorCode::kArmFault);
      break;
    case 2:
      note("arm: disconnected");
      arm_->set_phase(drivers::ArmPhase::kDisconnected, ErrorCode::kArmDisconnected);
      break;
    default:
      note("arm: controller reset mid-task (busy -> idle)");
      arm_->set_phase(drivers::ArmPhase::kIdle);
      break;
  }
}

void World::quiesce() {
  note("quiesce");
  alive_ = true;
  key_.reset();
  card_->fail_next_calls(0);
  clear_card_misbehaviour();
  stops_never_rest_ = false;
  card_->set_stops_never_rest(false);
  arm_clears_up();
  if (controller_ == nullptr) controller_ = connect(protocol::Role::kController, true, 0x55);
  // Bounded: every deadline (motion, stop, arm task, recovery, command timeout) is far shorter.
  const auto settled = [&] {
    const auto st = engine_->status().state;
    return !card_->any_moving() && motion_open_ == 0 && st != ProcedureState::kAligning &&
           st != ProcedureState::kEngaging;
  };
  for (int i = 0; i < 3000 && violation_.empty() && !settled(); ++i)
    cycle(true);
  if (engine_->status().latched_fault != ErrorCode::kOk) {
    read(*controller_, {protocol::Message{protocol::Reset{}}});
  }
  for (int i = 0; i < 1000 && violation_.empty(); ++i) {
    cycle(true);
    if (i >= 20 && settled() && engine_->status().card == protocol::DriverState::kActive) break;
  }
  if (!violation_.empty()) return;
  const auto status = engine_->status();
  if (card_->any_moving()) return fail("the wheels still move after quiescing");
  if (motion_open_ != 0) return fail("a motion_started was never closed");
  if (status.state == ProcedureState::kAligning || status.state == ProcedureState::kEngaging) {
    return fail(std::string("still ") + std::string(protocol::to_string(status.state)));
  }
  if (status.latched_fault == ErrorCode::kOk && status.card != protocol::DriverState::kActive) {
    return fail("no fault latched but the card is not active after a Reset");
  }
  if ((status.latched_fault != ErrorCode::kOk) != fault_event_open_) {
    return fail("latched fault and fault_latched events disagree");
  }
  // Held replies are released once their saves settle (the writer thread, in real time).
  for (int i = 0; i < 5000; ++i) {
    engine_->poll();
    hub_->tick(daemon::SessionHub::Clock::now());
    drain_all();
    if (!violation_.empty()) return;
    bool waiting = false;
    for (auto& l : links_)
      waiting = waiting || !l->expected.empty();
    if (!waiting) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  fail("a request never got its reply (a held Ack was never released)");
}

}  // namespace ajar::testing::interleaving
