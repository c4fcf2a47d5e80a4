// Protocol 1.1: a 1.0 session gets 1.0 frames, the robot model, loop statistics, non-finite
// Drive velocities, absent structures all zero, one clock for every stamp.
#include "suite.hpp"

#include <set>

#include <Eigen/Core>
#include <Eigen/LU>

namespace ajar::conformance {

std::string Suite::hello_1_0(Client& c) {
  protocol::Hello hello;
  hello.version_minor = 0;
  hello.requested_role = Role::kObserver;
  hello.client_instance_id = c.client_instance_id();
  hello.client_name = "ajarctl conformance 1.0";
  const std::uint32_t id = c.next_request_id();
  auto welcome = raw(c, frame_bytes(protocol::Envelope{id, 0, hello}, 0), id);
  if (!welcome || !std::holds_alternative<protocol::Welcome>(welcome->message)) {
    return "Hello 1.0: " + describe(welcome);
  }
  return {};
}

void Suite::protocol_1_1() {
  protocol_1_1_sessions();
  protocol_1_1_new_types();
  protocol_1_1_requests();
  protocol_1_1_values();
}

// Welcome's minor and driver kind; a 1.0 session gets 1.0 frames.
void Suite::protocol_1_1_sessions() {
  check("1.1: Welcome says minor 1 and a defined driver_kind", [&] {
    auto c = open();
    if (!c) return std::string("cannot connect");
    const Response r = c->hello(Role::kObserver);
    const auto* w = r.get<protocol::Welcome>();
    if (!w) return "Hello: " + describe(r);
    if (w->version_minor < 1) {
      return "Welcome.version_minor is " + std::to_string(w->version_minor) + ": a 1.0 daemon";
    }
    const auto kind = static_cast<unsigned>(w->driver_kind);
    if (kind > static_cast<unsigned>(protocol::DriverKind::kReal)) {
      return "driver_kind " + std::to_string(kind) + " is not defined";
    }
    return std::string{};
  });
  check(
      "1.1: a 1.0 session gets 1.0 frames (header minor 0; Welcome 72, Status 285, "
      "Telemetry 87 bytes)",
      [&] {
        std::atomic<int> telemetry{0};  // before the client: its callback may run until then
        auto c = open();
        if (!c) return std::string("cannot connect");
        c->on_telemetry([&](const protocol::Telemetry&) { ++telemetry; });
        c->record_headers(true);
        if (auto e = hello_1_0(*c); !e.empty()) return e;
        const std::uint32_t sub = c->next_request_id();
        auto ack =
            raw(*c, frame_bytes(protocol::Envelope{sub, 0, protocol::Subscribe{50.0f}}, 0), sub);
        if (!ack || !std::holds_alternative<protocol::Ack>(ack->message)) {
          return "Subscribe: " + describe(ack);
        }
        const auto deadline = Clock::now() + timeout();
        while (telemetry.load() < 2 && Clock::now() < deadline)
          std::this_thread::sleep_for(Milliseconds{10});
        const std::uint32_t get = c->next_request_id();
        auto st = raw(*c, frame_bytes(protocol::Envelope{get, 0, protocol::GetStatus{}}, 0), get);
        const std::uint32_t off = c->next_request_id();
        (void)raw(*c, frame_bytes(protocol::Envelope{off, 0, protocol::Subscribe{0.0f}}, 0), off);
        c->on_telemetry(nullptr);
        const auto headers = c->recorded_headers();
        c->record_headers(false);
        const std::map<MessageType, std::uint32_t> layout{{MessageType::kWelcome, 72},
                                                          {MessageType::kStatus, 285},
                                                          {MessageType::kTelemetry, 87}};
        std::set<MessageType> seen;
        for (const auto& h : headers) {
          const auto type = static_cast<MessageType>(h.type);
          const std::string name(protocol::to_string(type));
          if (h.version_minor != 0) {
            return name + " frame says minor " + std::to_string(h.version_minor) +
                   " in a 1.0 session";
          }
          if (auto it = layout.find(type); it != layout.end()) {
            if (h.payload_length != it->second) {
              return name + " has " + std::to_string(h.payload_length) + " bytes; 1.0 has " +
                     std::to_string(it->second);
            }
            seen.insert(type);
          }
        }
        if (!st || !std::holds_alternative<protocol::Status>(st->message)) {
          return "GetStatus: " + describe(st);
        }
        if (seen.size() != layout.size()) {
          return "saw " + std::to_string(seen.size()) +
                 " of Welcome, Status, Telemetry (Telemetry frames decoded: " +
                 std::to_string(telemetry.load()) + ")";
        }
        return std::string{};
      });
}

// The types 1.1 added: unknown in a 1.0 session; GetRobotModel's answer.
void Suite::protocol_1_1_new_types() {
  check(
      "1.1: in a 1.0 session Drive, Approach, GetRobotModel, ResetLoopStatistics are "
      "UNKNOWN_MESSAGE_TYPE (header.type), in 1.0 and in 1.1 frames",
      [&] {
        auto c = open();
        if (!c) return std::string("cannot connect");
        if (auto e = hello_1_0(*c); !e.empty()) return e;
        for (const protocol::Message& m : {protocol::Message{protocol::Drive{0.05, 0}},
                                           protocol::Message{protocol::Approach{1.0}},
                                           protocol::Message{protocol::GetRobotModel{}},
                                           protocol::Message{protocol::ResetLoopStatistics{}}}) {
          for (const int minor : {1, 0}) {
            const std::uint32_t id = c->next_request_id();
            auto f = frame_bytes(protocol::Envelope{id, 0, m});
            if (minor == 0) {
              f[protocol::kOffsetVersionMinor] = 0;
              fix_crc(f);
            }
            if (auto e =
                    want_error(raw(*c, f, id), ErrorCode::kUnknownMessageType, "header.type", id);
                !e.empty()) {
              return std::string(protocol::to_string(protocol::type_of(m))) + " in a 1." +
                     std::to_string(minor) + " frame: " + e;
            }
          }
        }
        return still_usable(*c);
      });
  check(
      "1.1: GetRobotModel answers a plausible RobotModel (rigid camera_to_base, the Welcome's "
      "limits)",
      [&] {
        auto c = open();
        if (!c) return std::string("cannot connect");
        const Response h = c->hello(Role::kObserver);
        const auto* w = h.get<protocol::Welcome>();
        if (!w) return "Hello: " + describe(h);
        const Response r = c->request(protocol::GetRobotModel{});
        const auto* m = r.get<protocol::RobotModel>();
        if (!m) return "GetRobotModel: " + describe(r);
        model_ = *m;
        return robot_model_problems(*m, *w);
      });
}

// ResetLoopStatistics and Drive's refusals.
void Suite::protocol_1_1_requests() {
  check("1.1: ResetLoopStatistics needs the controller role and restarts the statistics", [&] {
    auto obs = greeted(Role::kObserver);
    auto ctl = greeted(Role::kController, true);
    if (!obs || !ctl) return std::string("cannot connect");
    if (auto e =
            want_error(obs->request(protocol::ResetLoopStatistics{}), ErrorCode::kNotController);
        !e.empty()) {
      return "observer: " + e;
    }
    const auto before = status(*ctl);
    const Response r = ctl->request(protocol::ResetLoopStatistics{});
    const auto* ack = r.get<protocol::Ack>();
    if (!ack || ack->acknowledged != MessageType::kResetLoopStatistics) {
      return "controller: expected Ack of ResetLoopStatistics, got " + describe(r);
    }
    const auto after = status(*ctl);
    if (!before || !after) return std::string("no status");
    if (before->timing.all.samples > 100 &&
        !(after->timing.all.samples < before->timing.all.samples)) {
      return "timing.all.samples went from " + std::to_string(before->timing.all.samples) + " to " +
             std::to_string(after->timing.all.samples) + ": not restarted";
    }
    // loop.cycles restarts too (over the same span as loop.overruns and timing.all; Status reads
    // loop before timing): a daemon that keeps counting since start shows all its earlier cycles.
    if (after->loop.cycles > after->timing.all.samples + 2) {
      return "loop.cycles is " + std::to_string(after->loop.cycles) + " right after the reset (" +
             std::to_string(after->timing.all.samples) +
             " timing samples since): it did not restart";
    }
    return std::string{};
  });
  check("1.1: Drive with a NaN / infinite velocity is NON_FINITE_NUMBER naming the field", [&] {
    auto c = greeted(Role::kObserver);
    if (!c) return std::string("cannot connect");
    const std::pair<const char*, std::uint64_t> cases[] = {
        {"linear_m_s", 0x7ff8000000000000ull}, {"angular_rad_s", 0x7ff0000000000000ull}};
    std::size_t offset = 0;
    for (const auto& [field, bits] : cases) {
      const std::uint32_t id = c->next_request_id();
      auto f = frame_bytes(protocol::Envelope{id, 0, protocol::Drive{0.05, 0.1}});
      put_f64(f, protocol::kHeaderSize + offset, bits);
      offset += 8;
      fix_crc(f);
      const auto reply = raw(*c, f, id);
      if (auto e = want_error(reply, ErrorCode::kNonFiniteNumber, field, id); !e.empty()) return e;
      const auto& message = std::get<protocol::ErrorReply>(reply->message).message;
      if (message.view().find(field) == std::string_view::npos) {
        return "the sentence does not name " + std::string(field) + ": '" +
               std::string(message.view()) + "'";
      }
    }
    return still_usable(*c);
  });
}

// Absent structures are zero; one clock for every stamp.
void Suite::protocol_1_1_values() {
  check("1.1: absent structures are all zero (after Reset{clear} the plane's normal is (0, 0, 0))",
        [&] {
          auto c = greeted(Role::kController, true);
          if (!c) return std::string("cannot take control");
          if (auto e = want_ack(c->request(protocol::Reset{true}), ProcedureState::kAwaitingWidth);
              !e.empty()) {
            return "Reset: " + e;
          }
          const auto s = status(*c);
          if (!s) return std::string("no status");
          if (s->has_width || s->has_handle || s->has_plane || s->has_contact) {
            return std::string("a measurement is still stored");
          }
          if (!s->plane.normal.isZero(0) || !s->width.p1_base_m.isZero(0) ||
              !s->contact.contact_base_m.isZero(0) || s->plane.yaw_deviation_rad != 0) {
            return "absent values are not zero (plane.normal = " + json_vec3(s->plane.normal) + ")";
          }
          return std::string{};
        });
  check("1.1: one clock: Pong, Event and Telemetry stamps all count from daemon start", [&] {
    std::mutex m;  // before the clients: their callbacks may run until they are gone
    std::optional<std::uint64_t> telemetry_ns, event_ns;
    auto obs = greeted(Role::kObserver);
    if (!obs) return std::string("cannot connect");
    obs->on_telemetry([&](const protocol::Telemetry& t) {
      std::lock_guard lock(m);
      if (!telemetry_ns) telemetry_ns = t.daemon_time_ns;
    });
    obs->on_event([&](const protocol::Event& e) {
      std::lock_guard lock(m);
      if (e.kind == protocol::EventKind::kControlChanged && !event_ns) event_ns = e.daemon_time_ns;
    });
    const Response pong = obs->request(protocol::Ping{1});
    const auto* p = pong.get<protocol::Pong>();
    if (!p) return "Ping: " + describe(pong);
    if (auto e = want<protocol::Ack>(obs->request(protocol::Subscribe{50.0f})); !e.empty())
      return "Subscribe: " + e;
    {
      auto ctl = greeted(Role::kController, true);  // a control_changed for the observer
      if (!ctl) return std::string("cannot take control");
    }
    const auto deadline = Clock::now() + timeout();
    bool both = false;
    while (!both && Clock::now() < deadline) {
      {
        std::lock_guard lock(m);
        both = telemetry_ns && event_ns;
      }
      std::this_thread::sleep_for(Milliseconds{10});
    }
    (void)obs->request(protocol::Subscribe{0.0f});
    obs->on_telemetry(nullptr);
    obs->on_event(nullptr);
    std::lock_guard lock(m);
    if (!telemetry_ns || !event_ns) return std::string("no Telemetry or no control_changed Event");
    // Stamps of one clock taken within this check lie within seconds of each other; a stamp
    // since boot would be off by the machine's uptime at the daemon's start.
    const double pong_s = static_cast<double>(p->daemon_time_ns) * 1e-9;
    const double telemetry_s = static_cast<double>(*telemetry_ns) * 1e-9;
    const double event_s = static_cast<double>(*event_ns) * 1e-9;
    const double spread =
        std::max({pong_s, telemetry_s, event_s}) - std::min({pong_s, telemetry_s, event_s});
    if (spread > 30) {
      return "stamps " + json_number(pong_s) + " s (Pong), " + json_number(telemetry_s) +
             " s (Telemetry), " + json_number(event_s) + " s (Event): not one clock";
    }
    return std::string{};
  });
}

std::string Suite::robot_model_problems(const protocol::RobotModel& m, const protocol::Welcome& w) {
  std::string wrong;
  auto need = [&](bool ok, const std::string& what) {
    if (!ok) wrong += (wrong.empty() ? "" : "; ") + what;
  };
  need(m.wheel_radius_m > 0 && m.wheel_radius_m <= 1,
       "wheel_radius_m " + json_number(m.wheel_radius_m) + " not in (0, 1]");
  need(m.turning_radius_m > 0 && m.turning_radius_m <= 5,
       "turning_radius_m " + json_number(m.turning_radius_m) + " not in (0, 5]");
  need(m.encoder_counts_per_rev >= 1, "encoder_counts_per_rev below 1");
  need(m.gear_ratio > 0, "gear_ratio not positive");
  need(m.left.card_axis >= 1 && m.right.card_axis >= 1 && m.left.card_axis != m.right.card_axis,
       "wheel card axes not distinct axes from 1");
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      rotation(r, c) = m.camera_to_base[static_cast<std::size_t>(r * 4 + c)];
    translation(r) = m.camera_to_base[static_cast<std::size_t>(r * 4 + 3)];
  }
  const double orthogonality =
      (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  need(orthogonality < 1e-6 && std::abs(rotation.determinant() - 1) < 1e-6,
       "camera_to_base is not rigid (|R Rt - I| = " + json_number(orthogonality) +
           ", det R = " + json_number(rotation.determinant()) + ")");
  need(translation.norm() < 5, "camera_to_base translation above 5 m");
  need(m.min_door_width_m < m.max_door_width_m, "door width range empty");
  need(m.min_handle_length_m < m.max_handle_length_m, "handle length range empty");
  need(m.min_depth_m < m.max_depth_m, "depth range empty");
  need(m.arm_min_reach_m < m.arm_max_reach_m && m.arm_min_z_m < m.arm_max_z_m,
       "arm workspace empty");
  for (const double v :
       {m.max_linear_speed_m_s, m.max_angular_speed_rad_s, m.max_linear_accel_m_s2,
        m.max_angular_accel_rad_s2, m.drive_command_timeout_s, m.approach_max_travel_m,
        m.approach_square_tolerance_rad, m.approach_min_standoff_m, m.stale_travel_m,
        m.stale_yaw_rad, m.max_wheel_speed_rad_s, m.max_wheel_accel_rad_s2}) {
    need(v >= 0, "a drive/approach/staleness limit is negative (" + json_number(v) + ")");
  }
  // The Welcome's f32 limits are the model's, rounded to f32.
  const std::pair<const char*, std::pair<double, float>> same[] = {
      {"min_door_width_m", {m.min_door_width_m, w.min_door_width_m}},
      {"max_door_width_m", {m.max_door_width_m, w.max_door_width_m}},
      {"min_handle_length_m", {m.min_handle_length_m, w.min_handle_length_m}},
      {"max_handle_length_m", {m.max_handle_length_m, w.max_handle_length_m}},
      {"max_yaw_correction_rad", {m.max_yaw_correction_rad, w.max_yaw_correction_rad}}};
  for (const auto& [name, values] : same) {
    need(static_cast<float>(values.first) == values.second,
         std::string(name) + " differs from the Welcome's");
  }
  return wrong;
}

}  // namespace ajar::conformance
