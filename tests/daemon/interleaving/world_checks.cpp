// The interleaving world's invariants (docs/control-loop.md, "Proof"), checked after every command
// and every loop cycle (world.hpp).
#include "world.hpp"

#include "ajar/core/driving.hpp"
#include "det_mock_card.hpp"

namespace ajar::testing::interleaving {

void World::on_executed(const protocol::Message& m, const protocol::Message& reply,
                        const protocol::Status& before, std::ostringstream& line) {
  const auto* ack = std::get_if<protocol::Ack>(&reply);
  line << " -> ";
  if (ack != nullptr) {
    line << "ack " << protocol::to_string(ack->state);
  } else if (const auto* e = std::get_if<protocol::ErrorReply>(&reply)) {
    line << "refused " << to_string(e->code);
  }
  note(line.str());
  const bool is_stop = std::holds_alternative<protocol::Stop>(m) ||
                       std::holds_alternative<protocol::EmergencyStop>(m) ||
                       std::holds_alternative<protocol::Reset>(m);
  if (is_stop) {
    if (ack == nullptr && !reset_refused_by_the_arm(reply, before)) {
      return fail("a Stop/EmergencyStop/Reset was not acknowledged");
    }
    if (std::holds_alternative<protocol::Stop>(m) && open_kind_ == 'd' && card_jogging()) {
      coverage_.bump("jog stopped by a Stop");
    }
    stop_expected(std::holds_alternative<protocol::EmergencyStop>(m), "acknowledged stop");
    if (std::holds_alternative<protocol::Reset>(m)) {
      reset_seen_ = true;
      if (before.latched_fault != ErrorCode::kOk && ack != nullptr) {
        coverage_.bump("recovery (Reset of a fault)");
      }
    }
  }
  check_arm_on_executed(m, reply);
  if (ack == nullptr) return;
  if (std::holds_alternative<protocol::MeasureDoorPlane>(m)) {
    plane_ = std::get<protocol::PlaneAck>(ack->body);
    plane_yaw_odometry_rad_ = before.base_yaw_odometry_rad;
  }
  if (std::holds_alternative<protocol::AlignBase>(m) && ack->state == ProcedureState::kAligning) {
    if (before.latched_fault != ErrorCode::kOk) fail("AlignBase accepted with a fault latched");
    coverage_.bump("aligning");
    // The plane's yaw seen from where the base is now (a stop may have let it turn on since).
    const double turned = before.base_yaw_odometry_rad - plane_yaw_odometry_rad_;
    const auto wheels = core::wheel_command(plane_.yaw_deviation_rad - turned, config_.base);
    allowed_moves_.push_back(turned == 0 ? AllowedMove{plane_.left_counts, plane_.right_counts}
                                         : AllowedMove{wheels.left_counts, wheels.right_counts});
  }
  if (std::holds_alternative<protocol::Engage>(m) && ack->state == ProcedureState::kEngaging) {
    coverage_.bump("engaging");
  }
  if (const auto* d = std::get_if<protocol::Drive>(&m)) {
    if (before.latched_fault != ErrorCode::kOk) fail("Drive accepted with a fault latched");
    if (before.state == ProcedureState::kEngaging || before.state == ProcedureState::kEngaged) {
      fail("Drive accepted while the arm is at the door");
    }
    // A zero Drive permits no motion of its own; it may only update (slow) a running jog.
    if (d->linear_m_s != 0 || d->angular_rad_s != 0 || open_kind_ == 'd') jog_permit_ = true;
    last_drive_ns_ = now();
    coverage_.bump(d->linear_m_s == 0 && d->angular_rad_s == 0 ? "drive zero accepted"
                                                               : "drive accepted");
  }
  if (std::holds_alternative<protocol::Approach>(m)) {
    if (before.latched_fault != ErrorCode::kOk) fail("Approach accepted with a fault latched");
    if (before.state == ProcedureState::kEngaging || before.state == ProcedureState::kEngaged) {
      fail("Approach accepted while the arm is at the door");
    }
    const auto& body = std::get<protocol::ApproachAck>(ack->body);
    if (body.left_counts != 0 || body.right_counts != 0) {
      allowed_moves_.push_back({body.left_counts, body.right_counts, true});
    }
    coverage_.bump("approach accepted");
  }
}

void World::cycle(bool poll) {
  ++tick_;
  clock_.advance_ns(kPeriodNs);
  // The held key: the client re-sends its Drive (its own read).
  if (key_ && alive_ && controller_ != nullptr && ++key_count_ % key_every_ == 0) {
    read(*controller_, {protocol::Message{*key_}});
  }
  // A live controller pings (any frame is a heartbeat); a silent one sends nothing.
  if (alive_ && controller_ != nullptr && tick_ % 4 == 0) {
    read(*controller_, {protocol::Message{protocol::Ping{static_cast<std::uint64_t>(now())}}});
  }
  const std::size_t calls_before = card_->log_size();
  engine_->run_loop_cycle();
  bool stop_call = false, estop_call = false;
  for (const auto& c : card_->log_from(calls_before)) {
    stop_call = stop_call || c.kind == CardCall::kSmoothStop || c.kind == CardCall::kEmergencyStop;
    estop_call = estop_call || c.kind == CardCall::kEmergencyStop;
    on_card_call(c);
  }
  check_wheels(estop_call);
  if (verbose_ && std::getenv("AJAR_DEBUG")) {
    const auto l = card_->peek(left_axis_), r = card_->peek(right_axis_);
    note("DEBUG fault " + std::string(to_string(engine_->status().latched_fault)) + " L mv " +
         std::to_string(l.moving) + " lim " + std::to_string(l.positive_limit) + " v " +
         std::to_string(card_->velocity(left_axis_)) + " R mv " + std::to_string(r.moving) +
         " lim " + std::to_string(r.positive_limit) + " v " +
         std::to_string(card_->velocity(right_axis_)) + " telemetry moving " +
         std::to_string(engine_->telemetry().moving));
  }
  // One period after an acknowledged stop: the wheels are commanded to stop (a silent card: in
  // the first cycle it answers again).
  if (stop_due_ && card_->answering()) {
    stop_due_ = false;
    if (estop_due_) {
      estop_due_ = false;
      if (count_calls(*card_, CardCall::kEmergencyStop, stop_call_) == 0)
        return fail("an acknowledged EmergencyStop did not reach the card in one period");
    }
    for (const int axis : {left_axis_, right_axis_}) {
      const auto st = card_->peek(axis);
      // A stop call the card took since this motion began (applied or not: a stop the card did
      // not apply has its own deadline, check_wheels).
      // A zero jog (coming to rest) counts too.
      const std::size_t began = card_->motion_call(axis);
      const auto since = card_->log_from(began);
      const bool told = count_calls(*card_, CardCall::kSmoothStop, began) +
                                count_calls(*card_, CardCall::kEmergencyStop, began) >
                            0 ||
                        (!since.empty() && since.front().kind == CardCall::kJog &&
                         since.front().velocity_counts_per_ms(axis) == 0);
      if (st.moving && !st.smooth_stopped && began < stop_call_ && !told) {
        return fail("the wheels were not commanded to stop within one period of a stop");
      }
    }
  }
  check_jog(stop_call || !card_->answering());  // a silent card: the loop stopped, untold
  if (poll) {
    engine_->poll();
    hub_->tick(daemon::SessionHub::Clock::now());
    drain_all();
  }
  check_now();
}

void World::stop_expected(bool emergency, const char* why) {
  (void)why;
  allowed_moves_.clear();  // moves accepted before a stop may never start
  jog_permit_ = false;     // nor may a jog accepted before it move the wheels
  stop_due_ = true;
  estop_due_ = estop_due_ || emergency;
  stop_call_ = card_->log_size();
}

bool World::card_jogging() {
  for (const int axis : {left_axis_, right_axis_}) {
    if (card_->jogging(axis) && !card_->peek(axis).smooth_stopped) return true;
  }
  return false;
}

void World::on_card_call(const drivers::CardCallRecord& c) {
  check_card_call(c, c.kind == CardCall::kMoveRelative && !allowed_moves_.empty() &&
                         allowed_moves_.front().straight);
  const std::int64_t left = c.distance_counts(left_axis_), right = c.distance_counts(right_axis_);
  const double left_velocity = c.velocity_counts_per_ms(left_axis_);
  const double right_velocity = c.velocity_counts_per_ms(right_axis_);
  switch (c.kind) {
    case CardCall::kMoveRelative: {
      note("card: move " + std::to_string(left) + ", " + std::to_string(right));
      jog_left_ = jog_right_ = 0;
      if (allowed_moves_.empty()) {
        return fail(
            "the card was told to move without an accepted AlignBase or Approach since the last "
            "stop");
      }
      const AllowedMove allowed = allowed_moves_.front();
      allowed_moves_.pop_front();
      if (left != allowed.left || right != allowed.right)
        return fail("the card moved other counts than accepted");
      return;
    }
    case CardCall::kJog: {
      const bool moves = c.jogs();
      if (verbose_) {
        note("card: jog " + std::to_string(left_velocity) + ", " + std::to_string(right_velocity) +
             " counts/ms");
      }
      if (moves && !jog_permit_) {
        return fail(
            "a jog moved the wheels without an accepted Drive since the last acknowledged "
            "stop");
      }
      if (moves && now() - last_drive_ns_ > jog_bound_ns_) {
        return fail(
            "a jog still moves the wheels longer than drive.command_timeout_s plus the "
            "deceleration after the last accepted Drive");
      }
      if (std::abs(left_velocity) > max_wheel_counts_per_ms_ * (1 + 1e-9) ||
          std::abs(right_velocity) > max_wheel_counts_per_ms_ * (1 + 1e-9)) {
        return fail("a jog above base.max_wheel_speed_rad_s reached the card");
      }
      // Wheel acceleration: at most the body limits' worth (x2 for the scaling of a saturated
      // wheel pair) per second since the last jog call; a jog from rest starts within a period.
      const auto& d = config_.drive;
      const double dt_s =
          static_cast<double>(jog_left_ == 0 && jog_right_ == 0 ? kPeriodNs
                                                                : now() - last_jog_ns_) /
          1e9;
      const double max_step = 2 *
                                  (d.max_linear_accel_m_s2 +
                                   d.max_angular_accel_rad_s2 * config_.base.turning_radius_m) /
                                  config_.base.wheel_radius_m * counts_per_ms_per_rad_s_ * dt_s +
                              kEps;
      if (std::abs(left_velocity - jog_left_) > max_step ||
          std::abs(right_velocity - jog_right_) > max_step) {
        return fail("a jog's wheel velocity changed faster than the acceleration limits allow");
      }
      jog_left_ = left_velocity;
      jog_right_ = right_velocity;
      last_jog_ns_ = now();
      return;
    }
    case CardCall::kSmoothStop:
    case CardCall::kEmergencyStop:
      jog_left_ = jog_right_ = 0;
      return;
    default:
      return;
  }
}

void World::check_jog(bool stop_call) {
  if (!violation_.empty()) return;
  const auto st = engine_->status();
  const auto& d = config_.drive;
  const double lin = st.commanded_linear_m_s, ang = st.commanded_angular_rad_s;
  if (std::abs(lin) > d.max_linear_speed_m_s + kEps ||
      std::abs(ang) > d.max_angular_speed_rad_s + kEps) {
    return fail(
        "the commanded velocity exceeds drive.max_linear_speed_m_s / "
        "max_angular_speed_rad_s");
  }
  const double dt_s = static_cast<double>(kPeriodNs) / 1e9;
  const bool to_rest = lin == 0 && ang == 0;
  // commanded_* is what the wheels are told: at the wheel-speed cap both wheels are scaled, and the
  // scaled body velocity slides along the cap faster than the limiter's steps (the card's ramp
  // bounds the wheels there: check_card_call checks the jog calls' wheel acceleration).
  const auto& b = config_.base;
  const auto at_wheel_cap = [&](double v, double w) {
    return std::abs(v) + std::abs(w) * b.turning_radius_m >=
           b.max_wheel_speed_rad_s * b.wheel_radius_m - 1e-9;
  };
  const bool capped = at_wheel_cap(lin, ang) || at_wheel_cap(commanded_lin_, commanded_ang_);
  if (!(to_rest && stop_call) && !capped &&
      (std::abs(lin - commanded_lin_) > d.max_linear_accel_m_s2 * dt_s + kEps ||
       std::abs(ang - commanded_ang_) > d.max_angular_accel_rad_s2 * dt_s + kEps)) {
    return fail("the commanded velocity changed faster than drive.max_*_accel allow");
  }
  commanded_lin_ = lin;
  commanded_ang_ = ang;
  if (card_jogging() && now() - last_drive_ns_ > jog_rest_ns_ && now() > silent_until_ns_) {
    return fail(
        "the wheels still jog longer than drive.command_timeout_s plus the deceleration (and the "
        "jog's deadline to rest) after the last accepted Drive");
  }
}

void World::on_event(const protocol::Event& e) {
  std::ostringstream line;
  line << "  event " << static_cast<int>(e.kind) << " " << e.detail.view();
  note(line.str());
  const std::string_view detail = e.detail.view();
  switch (e.kind) {
    case EventKind::kMotionStarted:
      if (motion_open_ != 0) fail("motion_started while another motion is open");
      ++motion_open_;
      open_kind_ = detail.starts_with("driving")       ? 'd'
                   : detail.starts_with("approaching") ? 'p'
                   : detail.starts_with("aligning")    ? 'a'
                                                       : 'e';
      break;
    case EventKind::kMotionFinished:
    case EventKind::kMotionStopped:
      if (motion_open_ == 0) fail("motion_finished/stopped without an open motion_started");
      if (motion_open_ > 0) --motion_open_;
      if (e.kind == EventKind::kMotionFinished && open_kind_ == 'p')
        coverage_.bump("approach finished");
      if (e.kind == EventKind::kMotionStopped && open_kind_ == 'p')
        coverage_.bump("approach stopped");
      if (e.kind == EventKind::kMotionFinished && open_kind_ == 'd' &&
          detail.find("drive.command_timeout_s") != std::string_view::npos) {
        coverage_.bump("jog ended by the command timeout");
      }
      if (e.kind == EventKind::kMotionFinished && open_kind_ == 'a')
        coverage_.bump("alignment finished");
      if (e.kind == EventKind::kMotionFinished && open_kind_ == 'e')
        coverage_.bump("arm task finished");
      if (e.kind == EventKind::kMotionFinished && open_kind_ == 'd' &&
          detail.find("at rest") != std::string_view::npos)
        coverage_.bump("jog ended by a zero Drive");
      if (detail.find("cancelled before it started") != std::string_view::npos)
        coverage_.bump("move cancelled before it started");
      if (open_kind_ == 'a' || open_kind_ == 'p') allowed_moves_.clear();  // its permit ends
      if (open_kind_ == 'd') jog_permit_ = false;
      if (open_kind_ == 'd') card_->drop_next_calls(CardCall::kJog, 0);  // that jog's updates
      open_kind_ = 0;
      break;
    case EventKind::kFaultLatched:
      if (fault_event_open_) fail("a second fault_latched event for one latch");
      if (e.fault == ErrorCode::kDeadman) coverage_.bump("deadman");
      coverage_.bump("fault " + std::string(to_string(e.fault)));
      fault_event_open_ = true;
      break;
    case EventKind::kFaultCleared:
      fault_event_open_ = false;
      break;
    default:
      break;
  }
}

void World::check_now() {
  check_arm_interlock();
  if (!violation_.empty()) return;
  const ErrorCode fault = engine_->status().latched_fault;
  if (last_fault_ != ErrorCode::kOk && fault != last_fault_ && !reset_seen_) {
    return fail("the latched fault " + std::string(to_string(last_fault_)) + " became " +
                std::string(to_string(fault)) + " without a Reset");
  }
  if (fault != ErrorCode::kOk && !fault_event_open_) {
    return fail("a fault is latched but no fault_latched event was sent");
  }
  last_fault_ = fault;
  reset_seen_ = false;
}

void World::fail(const std::string& what) {
  if (violation_.empty()) violation_ = what;
}

void World::note(const std::string& line) {
  std::ostringstream out;
  out << '[' << tick_ << " t=" << now() / 1'000'000 << "ms] " << line;
  trace_.push_back(out.str());
  if (verbose_) std::cerr << trace_.back() << "\n";
}

int World::pick(int n) {
  return static_cast<int>(rng_() % static_cast<std::uint64_t>(n));
}

}  // namespace ajar::testing::interleaving
