// The procedure (paper Fig. 4) with every refusal on the way.
#include "suite.hpp"

#include <numbers>

namespace ajar::conformance {

// ---- the procedure, with every refusal on the way ----
void Suite::procedure() {
  auto c = greeted(Role::kController, true);
  if (!c) {
    check("procedure: take control", [] { return std::string("cannot take control"); });
    return;
  }
  c->set_heartbeat(Milliseconds{100});
  (void)c->request(protocol::Reset{true});
  procedure_width_and_handle(*c);
  procedure_plane(*c);
  if (!motion_refused_.empty()) {  // the rest turns the base and engages the arm
    check("procedure: align, contact point, engage", [&] { return skip(motion_refused_); });
    return;
  }
  procedure_motion(*c);
}

// `m` is refused with `code` (and `field`) and the procedure's state stays as it was.
void Suite::refuse_keeping_state(Client& c, const std::string& name, const protocol::Message& m,
                                 ErrorCode code, const char* field) {
  const auto type = protocol::type_of(m);
  // A daemon that wrongly accepted one of these would move the base or the arm.
  const bool moves = type == MessageType::kAlignBase || type == MessageType::kEngage;
  std::invoke(moves ? &Suite::moving : &Suite::check, this,
              "procedure: " + name + " -> " + std::string(ajar::to_string(code)), [&] {
                const auto before = status(c);
                if (auto e = want_error(c.request(m), code, field); !e.empty()) return e;
                const auto after = status(c);
                if (!before || !after || before->state != after->state) {
                  return std::string("the refusal changed the state");
                }
                return std::string{};
              });
}

// Nothing measured yet, then the door width and the handle with their refusals.
void Suite::procedure_width_and_handle(Client& c) {
  const protocol::SetContactPoint reachable{base_point(0.8, 0.0, 0.3)};
  // Nothing measured yet.
  refuse_keeping_state(
      c, "MeasureHandle first",
      protocol::MeasureHandle{base_point(0.95, -0.35, 0.3), base_point(0.95, -0.23, 0.3)},
      ErrorCode::kMissingDoorWidth);
  refuse_keeping_state(c, "MeasureDoorPlane first", door_plane(0.05), ErrorCode::kMissingDoorWidth);
  refuse_keeping_state(c, "SetContactPoint first", reachable, ErrorCode::kMissingDoorWidth);
  refuse_keeping_state(c, "AlignBase first", protocol::AlignBase{}, ErrorCode::kMissingDoorWidth);
  refuse_keeping_state(c, "Engage first", protocol::Engage{}, ErrorCode::kMissingDoorWidth);
  // Door width validation.
  refuse_keeping_state(c, "width point too near the camera",
                       protocol::MeasureDoorWidth{framed(core::Frame::kCamera, -0.4, 0, 0.1),
                                                  framed(core::Frame::kCamera, 0.4, 0, 1.0)},
                       ErrorCode::kPointOutOfDepthRange);
  refuse_keeping_state(c, "width with P1 = P2",
                       protocol::MeasureDoorWidth{base_point(1, 0.2, 0.3), base_point(1, 0.2, 0.3)},
                       ErrorCode::kPointsTooClose);
  refuse_keeping_state(c, "width with y1 = y2",
                       protocol::MeasureDoorWidth{base_point(1, 0.2, 0.0), base_point(1, 0.2, 0.8)},
                       ErrorCode::kAmbiguousDirection);
  refuse_keeping_state(c, "width mostly in height",
                       protocol::MeasureDoorWidth{base_point(1, 0.2, 0.0), base_point(1, 0.1, 0.9)},
                       ErrorCode::kPointsNotSideBySide);
  refuse_keeping_state(
      c, "width of 3 m",
      protocol::MeasureDoorWidth{base_point(1.5, 1.5, 0.3), base_point(1.5, -1.5, 0.3)},
      ErrorCode::kWidthOutOfRange, "width_m");
  check("procedure: Algorithm 1 answers CW when y1 < y2", [&] {
    const Response r =
        c.request(protocol::MeasureDoorWidth{base_point(1, -0.45, 0.3), base_point(1, 0.45, 0.3)});
    const auto* ack = r.get<protocol::Ack>();
    const auto* span = ack ? std::get_if<protocol::SpanAck>(&ack->body) : nullptr;
    if (!span) return "got " + describe(r);
    if (span->direction != core::RotationDirection::kClockwise) return std::string("not CW");
    return std::string{};
  });
  check("procedure: door width 0.9 m CCW, points echoed in the base frame", [&] {
    const Response r =
        c.request(protocol::MeasureDoorWidth{base_point(1, 0.45, 0.3), base_point(1, -0.45, 0.3)});
    if (auto e = want_ack(r, ProcedureState::kAwaitingHandle); !e.empty()) return e;
    const auto* span = std::get_if<protocol::SpanAck>(&r.get<protocol::Ack>()->body);
    if (!span) return std::string("Ack without a span body");
    if (!near(span->length_m, 0.9, 1e-9)) return "width " + json_number(span->length_m);
    if (span->direction != core::RotationDirection::kCounterClockwise)
      return std::string("not CCW");
    if (!span->p1_base_m.isApprox(core::Vec3(1, 0.45, 0.3), 1e-9)) return std::string("p1 moved");
    return std::string{};
  });
  refuse_keeping_state(c, "MeasureDoorPlane before the handle", door_plane(0.05),
                       ErrorCode::kMissingHandle);
  refuse_keeping_state(c, "AlignBase before the handle", protocol::AlignBase{},
                       ErrorCode::kMissingHandle);
  refuse_keeping_state(
      c, "handle of 0.5 m",
      protocol::MeasureHandle{base_point(0.95, -0.3, 0.3), base_point(0.95, 0.2, 0.3)},
      ErrorCode::kHandleLengthOutOfRange, "handle_length_m");
  check("procedure: handle 0.12 m", [&] {
    const Response r = c.request(
        protocol::MeasureHandle{base_point(0.95, -0.35, 0.3), base_point(0.95, -0.23, 0.3)});
    if (auto e = want_ack(r, ProcedureState::kAwaitingPlane); !e.empty()) return e;
    const auto* span = std::get_if<protocol::SpanAck>(&r.get<protocol::Ack>()->body);
    if (!span || !near(span->length_m, 0.12, 1e-9)) return std::string("wrong handle length");
    return std::string{};
  });
  refuse_keeping_state(c, "AlignBase before the plane", protocol::AlignBase{},
                       ErrorCode::kMissingPlane);
  refuse_keeping_state(c, "SetContactPoint before the plane", reachable, ErrorCode::kMissingPlane);
}

// The door plane with its refusals, up to ready_to_align.
void Suite::procedure_plane(Client& c) {
  const protocol::SetContactPoint reachable{base_point(0.8, 0.0, 0.3)};
  // Plane validation.
  refuse_keeping_state(
      c, "collinear plane points",
      plane_of({base_point(1, -0.3, 0.3), base_point(1, 0, 0.3), base_point(1, 0.3, 0.3)}),
      ErrorCode::kPointsCollinear);
  refuse_keeping_state(
      c, "duplicate plane points",
      plane_of({base_point(1, -0.3, 0.0), base_point(1, -0.3, 0.0), base_point(1, 0.3, 0.5)}),
      ErrorCode::kPointsTooClose);
  refuse_keeping_state(
      c, "horizontal plane",
      plane_of({base_point(1, -0.3, -0.5), base_point(1.6, 0.3, -0.5), base_point(2, -0.2, -0.5)}),
      ErrorCode::kPlaneNotVertical);
  refuse_keeping_state(c, "yaw of 1.0 rad", door_plane(1.0, 1.5), ErrorCode::kYawOutOfRange,
                       "yaw_deviation_rad");
  refuse_keeping_state(
      c, "bumpy plane (rms > limit)",
      plane_of({door_point(1, 0, -0.3, 0.0, 0.1), door_point(1, 0, 0.3, 0.0, -0.1),
                door_point(1, 0, 0.3, 0.7, 0.1), door_point(1, 0, -0.3, 0.7, -0.1)}),
      ErrorCode::kPlaneResidualTooLarge, "rms_residual_m");
  check("procedure: plane turned +0.05 rad: signed yaw, wheels opposite", [&] {
    const Response r = c.request(door_plane(0.05));
    if (auto e = want_ack(r, ProcedureState::kReadyToAlign); !e.empty()) return e;
    const auto* p = std::get_if<protocol::PlaneAck>(&r.get<protocol::Ack>()->body);
    if (!p) return std::string("Ack without a plane body");
    if (!near(p->yaw_deviation_rad, 0.05, 1e-6)) return "yaw " + json_number(p->yaw_deviation_rad);
    if (!(p->left_wheel_rad < 0 && p->right_wheel_rad > 0)) {
      return std::string("CCW turn needs left wheel back, right wheel forward");
    }
    if (!(p->normal.x() < 0)) return std::string("normal not toward the robot");
    if (p->point_count != 4) return std::string("point_count not 4");
    return std::string{};
  });
  refuse_keeping_state(c, "SetContactPoint before aligning", reachable, ErrorCode::kNotAligned);
  refuse_keeping_state(c, "Engage before aligning", protocol::Engage{}, ErrorCode::kNotAligned);
}

// AlignBase (pipelined with a command that must wait), the contact point, Engage.
void Suite::procedure_motion(Client& c) {
  const protocol::SetContactPoint reachable{base_point(0.8, 0.0, 0.3)};
  check("procedure: AlignBase accepted; a command during the motion gets MOTION_IN_PROGRESS", [&] {
    const auto before = status(c);
    if (!before) return std::string("no status");
    yaw_before_align_ = before->base_yaw_odometry_rad;
    const std::uint32_t align_id = c.next_request_id();
    const std::uint32_t plane_id = c.next_request_id();
    // Pipelined: the second frame is handled while the base turns.
    c.send_envelope(protocol::Envelope{align_id, 0, protocol::AlignBase{}});
    c.send_envelope(protocol::Envelope{plane_id, 0, door_plane(0.05)});
    auto ack = c.wait_reply(align_id, timeout());
    auto busy = c.wait_reply(plane_id, timeout());
    const auto* a = ack ? std::get_if<protocol::Ack>(&ack->message) : nullptr;
    if (!a || a->state != ProcedureState::kAligning) return "AlignBase: " + describe(ack);
    return want_error(busy, ErrorCode::kMotionInProgress);
  });
  check("procedure: the alignment finishes in state aligned; odometry turned +0.05 rad", [&] {
    const auto s = wait_not(c, ProcedureState::kAligning, 60);
    if (!s) return std::string("still aligning after 60 s");
    if (s->state != ProcedureState::kAligned) {
      return "ended in " + std::string(protocol::to_string(s->state)) + ", fault " +
             std::string(ajar::to_string(s->latched_fault));
    }
    const double turned =
        std::remainder(s->base_yaw_odometry_rad - yaw_before_align_, 2 * std::numbers::pi);
    if (!near(turned, 0.05, 0.005)) return "odometry turned " + json_number(turned) + " rad";
    return std::string{};
  });
  refuse_keeping_state(c, "AlignBase when aligned", protocol::AlignBase{}, ErrorCode::kWrongState);
  refuse_keeping_state(c, "Engage without a contact point", protocol::Engage{},
                       ErrorCode::kMissingContactPoint);
  refuse_keeping_state(c, "contact point 3 m away",
                       protocol::SetContactPoint{base_point(3.0, 0, 0.3)}, ErrorCode::kOutOfReach,
                       "contact");
  check("procedure: contact point accepted in the base frame", [&] {
    const Response r = c.request(reachable);
    if (auto e = want_ack(r, ProcedureState::kReadyToEngage); !e.empty()) return e;
    const auto* ct = std::get_if<protocol::ContactAck>(&r.get<protocol::Ack>()->body);
    if (!ct || !ct->contact_base_m.isApprox(reachable.contact.position_m, 1e-9)) {
      return std::string("contact point not echoed");
    }
    if (!(ct->reach_margin_m >= 0)) return std::string("negative reach margin");
    return std::string{};
  });
  check("procedure: Engage hands over to the arm and ends engaged", [&] {
    const Response r = c.request(protocol::Engage{});
    const auto* ack = r.get<protocol::Ack>();
    if (!ack ||
        (ack->state != ProcedureState::kEngaging && ack->state != ProcedureState::kEngaged)) {
      return "expected Ack (engaging), got " + describe(r);
    }
    const auto s = wait_not(c, ProcedureState::kEngaging, 60);
    if (!s || s->state != ProcedureState::kEngaged) {
      return std::string("did not reach engaged");
    }
    return std::string{};
  });
}

}  // namespace ajar::conformance
