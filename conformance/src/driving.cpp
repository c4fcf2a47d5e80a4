// Driving (1.1): Drive and Approach, their refusals, the command timeout.
#include "suite.hpp"

#include <numbers>

#include "ajar/client/teleop.hpp"

namespace ajar::conformance {
namespace {

std::string measure_width_at(Client& k, double x_m) {
  return want_ack(k.request(protocol::MeasureDoorWidth{base_point(x_m, 0.45, 0.3),
                                                       base_point(x_m, -0.45, 0.3)}),
                  ProcedureState::kAwaitingHandle);
}

}  // namespace

void Suite::driving() {
  check("drive: an observer's Drive gets NOT_CONTROLLER", [&] {
    auto obs = greeted(Role::kObserver);
    if (!obs) return std::string("cannot connect");
    const Response r = obs->request(protocol::Drive{0.05, 0});
    if (auto s = not_supported(r); !s.empty()) return s;
    return want_error(r, ErrorCode::kNotController);
  });
  // Everything below is sent by the controller: a daemon that wrongly accepted it would move the
  // base, so it runs only where motion is allowed.
  std::unique_ptr<Client> c;
  if (motion_refused_.empty()) {
    c = greeted(Role::kController, true);
    if (c) {
      c->set_heartbeat(Milliseconds{100});
      (void)c->request(protocol::Reset{true});
    }
  }
  auto controller = [&](const std::string& name, const std::function<std::string(Client&)>& body) {
    moving(name, [&] { return c ? body(*c) : std::string("cannot take control"); });
  };
  const double min_standoff_m = model_ ? model_->approach_min_standoff_m : 0.0;
  const double timeout_s = model_ ? model_->drive_command_timeout_s : 0.0;
  controller("approach: with nothing measured -> NO_DOOR_DISTANCE", [&](Client& k) {
    (void)k.request(protocol::Reset{true});
    const Response r = k.request(protocol::Approach{1.0});
    if (auto s = not_supported(r); !s.empty()) return s;
    return want_error(r, ErrorCode::kNoDoorDistance);
  });
  controller(
      "approach: standoff below approach_min_standoff_m -> STANDOFF_OUT_OF_RANGE "
      "(standoff_m)",
      [&](Client& k) {
        if (auto e = measure_width_at(k, 1.2); !e.empty()) return "width: " + e;
        const Response r = k.request(protocol::Approach{min_standoff_m - 0.05});
        if (auto s = not_supported(r); !s.empty()) return s;
        return want_error(r, ErrorCode::kStandoffOutOfRange, "standoff_m");
      });
  controller(
      "drive: Drive is accepted, Telemetry shows the commanded velocity (within the limit), the "
      "base moves forward; Drive{0, 0} brings it to rest",
      [&](Client& k) { return drive_then_rest(k, timeout_s); });
  controller("drive: a Drive that is not re-sent stops after drive_command_timeout_s",
             [&](Client& k) { return drive_times_out(k, timeout_s); });
  controller(
      "approach: from 1.2 m to the standoff: ApproachBody (travel, start distance, counts), "
      "motion_finished, then the door distance is the standoff",
      [&](Client& k) { return approach_to_standoff(k, min_standoff_m); });
  if (c) {
    (void)c->request(protocol::Stop{});
    (void)c->request(protocol::Reset{true});
  }
}

// Drive at 0.05 m/s for 600 ms (re-sent within the timeout), then Drive{0, 0}: Telemetry shows the
// commanded velocity within what was asked, the base moved forward, then it rests.
std::string Suite::drive_then_rest(Client& k, double timeout_s) {
  auto tm = watch_telemetry(k);
  if (auto e = want<protocol::Ack>(k.request(protocol::Subscribe{50.0f})); !e.empty())
    return "Subscribe: " + e;
  const auto before = status(k);
  const double speed = 0.05;
  const auto period = client::teleop::resend_period(timeout_s);
  const auto end = Clock::now() + Milliseconds{600};
  while (Clock::now() < end) {
    const Response r = k.request(protocol::Drive{speed, 0});
    if (auto s = not_supported(r); !s.empty()) {
      k.on_telemetry(nullptr);
      return s;
    }
    if (!r.ok()) return "Drive: " + describe(r);
    std::this_thread::sleep_for(period);
  }
  std::uint64_t count = 0;
  {
    std::lock_guard lock(tm->mutex);
    count = tm->count;
  }
  if (auto e = want<protocol::Ack>(k.request(protocol::Drive{0, 0})); !e.empty())
    return "Drive{0, 0}: " + e;
  const bool rest = wait_at_rest(*tm, count, 10);
  (void)k.request(protocol::Subscribe{0.0f});
  k.on_telemetry(nullptr);
  const auto after = status(k);
  if (!rest) return std::string("not at rest 10 s after Drive{0, 0}");
  if (!before || !after) return std::string("no status");
  double max_commanded = 0;
  {
    std::lock_guard lock(tm->mutex);
    max_commanded = tm->max_commanded_linear_m_s;
  }
  if (!(max_commanded > 0)) return std::string("Telemetry never showed a commanded velocity");
  if (max_commanded > speed + 1e-9) {
    return "commanded " + json_number(max_commanded) + " m/s, more than the " + json_number(speed) +
           " m/s asked";
  }
  const double moved = after->odometry_x_m - before->odometry_x_m;
  if (!(moved > 0.002)) return "odometry x moved " + json_number(moved) + " m";
  return std::string{};
}

// One Drive, then only heartbeats: the command timeout alone brings the base to rest.
std::string Suite::drive_times_out(Client& k, double timeout_s) {
  auto tm = watch_telemetry(k);
  if (auto e = want<protocol::Ack>(k.request(protocol::Subscribe{50.0f})); !e.empty())
    return "Subscribe: " + e;
  const Response r = k.request(protocol::Drive{0.05, 0});
  if (auto s = not_supported(r); !s.empty()) {
    k.on_telemetry(nullptr);
    return s;
  }
  if (!r.ok()) return "Drive: " + describe(r);
  // Only heartbeat Pings from here on: the timeout alone must stop the base. First
  // the jog must show in Telemetry, then the base must come to rest after it.
  std::uint64_t seen = 0;
  const auto deadline = Clock::now() + Milliseconds{5000};
  while (seen == 0 && Clock::now() < deadline) {
    {
      std::lock_guard lock(tm->mutex);
      if (tm->max_commanded_linear_m_s > 0) seen = tm->count;
    }
    std::this_thread::sleep_for(Milliseconds{5});
  }
  if (seen == 0) {
    (void)k.request(protocol::Stop{});
    k.on_telemetry(nullptr);
    return std::string("Telemetry never showed the jog's commanded velocity");
  }
  const bool rest = wait_at_rest(*tm, seen, std::max(timeout_s, 0.5) + 10);
  (void)k.request(protocol::Subscribe{0.0f});
  k.on_telemetry(nullptr);
  if (!rest) {
    (void)k.request(protocol::Stop{});
    return "still moving " + json_number(std::max(timeout_s, 0.5) + 10) +
           " s after the only Drive (Stop sent)";
  }
  return std::string{};
}

// What is wrong with an Approach's Ack body from `start` m to `standoff` m ("": nothing).
std::string Suite::approach_ack_problem(const protocol::ApproachAck& ack, double start,
                                        double standoff) const {
  const protocol::ApproachAck* body = &ack;
  std::string wrong;
  if (!near(body->start_distance_m, start, 1e-3)) {
    wrong = "start_distance_m " + json_number(body->start_distance_m) + ", Status said " +
            json_number(start);
  } else if (!near(body->travel_m, body->start_distance_m - standoff, 1e-9)) {
    wrong = "travel_m " + json_number(body->travel_m) + " is not start - standoff";
  } else if (model_) {
    const double counts = body->travel_m / model_->wheel_radius_m / (2 * std::numbers::pi) *
                          model_->gear_ratio * model_->encoder_counts_per_rev;
    const double left = static_cast<double>(body->left_counts) * model_->left.polarity;
    const double right = static_cast<double>(body->right_counts) * model_->right.polarity;
    if (!near(left, counts, 1.0) || !near(right, counts, 1.0)) {
      wrong = "wheel counts " + std::to_string(body->left_counts) + " / " +
              std::to_string(body->right_counts) + " (card), expected " + json_number(counts) +
              " motor counts x polarity";
    }
  }
  return wrong;
}

// The event that ended a motion (finished, stopped, fault latched), waiting at most `seconds`.
std::optional<protocol::EventKind> Suite::wait_motion_end(EventWatch& events, double seconds) {
  std::optional<protocol::EventKind> end;
  const auto deadline = Clock::now() + Milliseconds{static_cast<std::int64_t>(seconds * 1e3)};
  while (!end && Clock::now() < deadline) {
    {
      std::lock_guard lock(events.mutex);
      for (const auto kind : events.kinds) {
        if (kind == protocol::EventKind::kMotionFinished ||
            kind == protocol::EventKind::kMotionStopped ||
            kind == protocol::EventKind::kFaultLatched) {
          end = kind;
        }
      }
    }
    std::this_thread::sleep_for(Milliseconds{20});
  }
  return end;
}

// Approach from 1.2 m to the standoff: the Ack's body, motion_finished, the door distance after.
std::string Suite::approach_to_standoff(Client& k, double min_standoff_m) {
  (void)k.request(protocol::Reset{true});
  if (auto e = measure_width_at(k, 1.2); !e.empty()) return "width: " + e;
  const auto before = status(k);
  if (!before || !before->door.has_distance) {
    // A daemon that does not drive yet has no distance either: say so rather than fail.
    if (auto s = not_supported(k.request(protocol::Approach{1.0})); !s.empty()) return s;
    return std::string("Status has no door distance after the width was measured");
  }
  const double start = before->door.distance_m;
  double standoff = std::max(min_standoff_m, 1.0);
  if (model_ && model_->approach_max_travel_m > 0 &&
      start - standoff > model_->approach_max_travel_m) {
    standoff = start - model_->approach_max_travel_m / 2;
  }
  auto events = std::make_shared<EventWatch>();
  k.on_event([events](const protocol::Event& e) {
    std::lock_guard lock(events->mutex);
    events->kinds.push_back(e.kind);
  });
  const Response r = k.request(protocol::Approach{standoff});
  if (auto s = not_supported(r); !s.empty()) {
    k.on_event(nullptr);
    return s;
  }
  const auto* ack = r.get<protocol::Ack>();
  const auto* body = ack ? std::get_if<protocol::ApproachAck>(&ack->body) : nullptr;
  if (!body) {
    k.on_event(nullptr);
    return "expected Ack with an ApproachBody, got " + describe(r);
  }
  const std::string wrong = approach_ack_problem(*body, start, standoff);
  // Wait for the end of the move, feeding the deadman.
  const std::optional<protocol::EventKind> end = wait_motion_end(*events, 60);
  k.on_event(nullptr);
  if (!wrong.empty()) return wrong;
  if (!end) return std::string("no motion_finished within 60 s");
  if (*end != protocol::EventKind::kMotionFinished) {
    return "the approach ended with " + std::string(protocol::to_string(*end));
  }
  const auto after = status(k);
  if (!after || !after->door.has_distance) return std::string("no door distance after");
  if (!near(after->door.distance_m, standoff, 0.01)) {
    return "door distance " + json_number(after->door.distance_m) + " m, standoff " +
           json_number(standoff) + " m";
  }
  return std::string{};
}

}  // namespace ajar::conformance
