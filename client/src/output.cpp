#include "ajar/client/output.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>

namespace ajar::client {

// Fixed-point text with `digits` decimals; `sign` forces a leading + on positive values.
std::string fixed(double value, int digits, bool sign) {
  char buffer[64];
  if (sign) {
    std::snprintf(buffer, sizeof buffer, "%+.*f", digits, value);
  } else {
    std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  }
  return buffer;
}

namespace {

std::string m(double v) {
  return fixed(v, 4) + " m";
}
std::string rad(double v) {
  std::string t = fixed(v, 5, true);
  t += " rad (";
  t += fixed(v * 180.0 / std::numbers::pi, 3, true);
  t += " deg)";
  return t;
}
std::string vec(const core::Vec3& v) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.4f, %.4f, %.4f) m", v.x(), v.y(), v.z());
  return buffer;
}

JsonObject left_right(double left, double right) {
  JsonObject o;
  o.add("left", left).add("right", right);
  return o;
}
JsonObject left_right(std::int64_t left, std::int64_t right) {
  JsonObject o;
  o.add("left", left).add("right", right);
  return o;
}

JsonObject loop_object(const protocol::LoopStatistics& loop) {
  JsonObject o;
  o.add("rate_hz", loop.rate_hz)
      .add("cycles", loop.cycles)
      .add("overruns", loop.overruns)
      .add("period_p50_ns", static_cast<std::uint64_t>(loop.period_p50_ns))
      .add("period_p99_ns", static_cast<std::uint64_t>(loop.period_p99_ns))
      .add("period_max_ns", static_cast<std::uint64_t>(loop.period_max_ns))
      .add("jitter_p99_ns", static_cast<std::uint64_t>(loop.jitter_p99_ns));
  return o;
}

std::string range(float lo, float hi) {
  std::string out(1, '[');
  out += json_number(static_cast<double>(lo));
  out += ", ";
  out += json_number(static_cast<double>(hi));
  out += ']';
  return out;
}

std::string state_name(protocol::ProcedureState s) {
  return std::string(protocol::to_string(s));
}

}  // namespace

JsonObject error_object(std::string_view code, std::string_view field, std::string_view message) {
  JsonObject o;
  o.add("code", code).add("field", field).add("message", message);
  return o;
}

JsonObject error_object(const protocol::ErrorReply& error) {
  JsonObject o =
      error_object(ajar::to_string(error.code), error.field.view(), error.message.view());
  o.add("number", static_cast<unsigned>(error.code));
  return o;
}

void add_span_fields(JsonObject& o, const protocol::SpanAck& span, std::string_view length_key) {
  o.add(length_key, span.length_m)
      .add("direction", core::to_string(span.direction))
      .add("p1_base_m", span.p1_base_m)
      .add("p2_base_m", span.p2_base_m);
}

void add_plane_fields(JsonObject& o, const protocol::PlaneAck& plane) {
  o.add("yaw_deviation_rad", plane.yaw_deviation_rad)
      .add("normal_base", plane.normal)
      .add("wheel_angle_rad", left_right(plane.left_wheel_rad, plane.right_wheel_rad))
      .add("wheel_counts", left_right(plane.left_counts, plane.right_counts))
      .add("residual_yaw_rad", plane.residual_yaw_rad)
      .add("rms_residual_m", plane.rms_residual_m)
      .add("point_count", static_cast<unsigned>(plane.point_count));
}

void add_contact_fields(JsonObject& o, const protocol::ContactAck& contact) {
  o.add("contact_base_m", contact.contact_base_m).add("reach_margin_m", contact.reach_margin_m);
}

JsonObject status_object(const protocol::Status& s) {
  JsonObject o;
  o.add("state", state_name(s.state))
      .add("latched_fault", ajar::to_string(s.latched_fault))
      .add("restored_from_disk", s.restored_from_disk)
      .add("controller_connected", s.controller_connected)
      .add("session_count", static_cast<unsigned>(s.session_count));
  if (s.has_width) {
    JsonObject w;
    add_span_fields(w, s.width, "width_m");
    o.add("width", w);
  }
  if (s.has_handle) {
    JsonObject h;
    add_span_fields(h, s.handle, "handle_length_m");
    o.add("handle", h);
  }
  if (s.has_plane) {
    JsonObject p;
    add_plane_fields(p, s.plane);
    o.add("plane", p);
  }
  if (s.has_contact) {
    JsonObject c;
    add_contact_fields(c, s.contact);
    o.add("contact", c);
  }
  o.add("base_yaw_odometry_rad", s.base_yaw_odometry_rad)
      .add("card", protocol::to_string(s.card))
      .add("arm", protocol::to_string(s.arm))
      .add("arm_state", protocol::to_string(s.arm_state))
      .add("loop", loop_object(s.loop));
  return o;
}

JsonObject welcome_object(const protocol::Welcome& w) {
  JsonObject o;
  o.add("version", std::to_string(w.version_major) + "." + std::to_string(w.version_minor))
      .add("role", protocol::to_string(w.granted_role))
      .add("session_id", w.session_id)
      .add("daemon_version", w.daemon_version.view())
      .add("loop_rate_hz", w.loop_rate_hz)
      .add("deadman_timeout_s", w.deadman_timeout_s)
      .add_raw("door_width_m", range(w.min_door_width_m, w.max_door_width_m))
      .add_raw("handle_length_m", range(w.min_handle_length_m, w.max_handle_length_m))
      .add("max_yaw_correction_rad", w.max_yaw_correction_rad);
  return o;
}

JsonObject response_object(std::string_view command, const Response& r) {
  JsonObject o;
  switch (r.outcome) {
    case Outcome::kTimeout:
    case Outcome::kDisconnected:
      o.add("type", "error").add("command", command).add("ok", false);
      o.add("error", error_object(r.outcome == Outcome::kTimeout ? kTimeoutCode : kDisconnectedCode,
                                  "", r.transport_error));
      return o;
    case Outcome::kRefused:
      o.add("type", "error").add("command", command).add("ok", false);
      o.add("request_id", static_cast<unsigned>(r.request_id));
      o.add("error", error_object(r.error));
      return o;
    case Outcome::kReply:
      break;
  }
  if (const auto* ack = r.get<protocol::Ack>()) {
    o.add("type", "ack").add("command", command).add("ok", true);
    o.add("acknowledged", protocol::to_string(ack->acknowledged));
    o.add("state", state_name(ack->state));
    o.add("request_id", static_cast<unsigned>(r.request_id));
    if (const auto* span = std::get_if<protocol::SpanAck>(&ack->body)) {
      add_span_fields(o, *span,
                      ack->acknowledged == protocol::MessageType::kMeasureHandle ? "handle_length_m"
                                                                                 : "width_m");
    } else if (const auto* plane = std::get_if<protocol::PlaneAck>(&ack->body)) {
      add_plane_fields(o, *plane);
    } else if (const auto* contact = std::get_if<protocol::ContactAck>(&ack->body)) {
      add_contact_fields(o, *contact);
    }
  } else if (const auto* status = r.get<protocol::Status>()) {
    o.add("type", "status").add("command", command).add("ok", true);
    JsonObject s = status_object(*status);
    o.add_raw("status", s.str());
  } else if (const auto* pong = r.get<protocol::Pong>()) {
    o.add("type", "pong").add("command", command).add("ok", true);
    o.add("daemon_time_ns", pong->daemon_time_ns);
  } else if (const auto* welcome = r.get<protocol::Welcome>()) {
    o.add("type", "welcome").add("command", command).add("ok", true);
    o.add("welcome", welcome_object(*welcome));
  } else {
    o.add("type", "reply").add("command", command).add("ok", true);
    o.add("message", protocol::to_string(protocol::type_of(r.reply)));
  }
  return o;
}

std::string status_text(const protocol::Status& s) {
  std::string t;
  t += "state:            " + state_name(s.state) + "\n";
  t += "latched fault:    " + std::string(ajar::to_string(s.latched_fault)) + "\n";
  t += "controller:       " + std::string(s.controller_connected ? "connected" : "none") + ", " +
       std::to_string(s.session_count) + " session(s)\n";
  if (s.has_width) {
    t += "door width:       " + m(s.width.length_m) + ", " + core::to_string(s.width.direction) +
         "\n";
  }
  if (s.has_handle) {
    t += "handle length:    " + m(s.handle.length_m) + ", " + core::to_string(s.handle.direction) +
         "\n";
  }
  if (s.has_plane) {
    t += "yaw deviation:    " + rad(s.plane.yaw_deviation_rad) + " from " +
         std::to_string(s.plane.point_count) + " points\n";
  }
  if (s.has_contact) t += "contact (base):   " + vec(s.contact.contact_base_m) + "\n";
  t += "odometry yaw:     " + rad(s.base_yaw_odometry_rad) + "\n";
  t += "card / arm:       " + std::string(protocol::to_string(s.card)) + " / " +
       std::string(protocol::to_string(s.arm)) + " (" +
       std::string(protocol::to_string(s.arm_state)) + ")";
  if (s.restored_from_disk) t += "\nparameters restored from disk";
  return t;
}

std::string response_text(std::string_view command, const Response& r) {
  const std::string cmd(command);
  switch (r.outcome) {
    case Outcome::kTimeout:
    case Outcome::kDisconnected:
      return cmd + ": " + std::string(to_string(r.outcome)) + ": " + r.transport_error;
    case Outcome::kRefused: {
      std::string t = cmd + ": refused: " + std::string(ajar::to_string(r.error.code));
      if (r.error.field.length > 0) t += " (" + std::string(r.error.field.view()) + ")";
      if (r.error.message.length > 0) t += ": " + std::string(r.error.message.view());
      return t;
    }
    case Outcome::kReply:
      break;
  }
  if (const auto* ack = r.get<protocol::Ack>()) {
    std::string t = cmd + ": ok, state " + state_name(ack->state);
    if (const auto* span = std::get_if<protocol::SpanAck>(&ack->body)) {
      t += ack->acknowledged == protocol::MessageType::kMeasureHandle ? "\n  handle length: "
                                                                      : "\n  door width:    ";
      t += m(span->length_m) + ", direction " + core::to_string(span->direction);
      t += "\n  p1 (base):     " + vec(span->p1_base_m);
      t += "\n  p2 (base):     " + vec(span->p2_base_m);
    } else if (const auto* plane = std::get_if<protocol::PlaneAck>(&ack->body)) {
      t += "\n  yaw deviation: " + rad(plane->yaw_deviation_rad);
      t += "\n  wheel angles:  left " + fixed(plane->left_wheel_rad, 5, true) + " rad, right " +
           fixed(plane->right_wheel_rad, 5, true) + " rad";
      t += "\n  wheel counts:  left " + std::to_string(plane->left_counts) + ", right " +
           std::to_string(plane->right_counts);
      t += "\n  plane fit:     " + std::to_string(plane->point_count) + " points, rms " +
           m(plane->rms_residual_m);
    } else if (const auto* contact = std::get_if<protocol::ContactAck>(&ack->body)) {
      t += "\n  contact (base): " + vec(contact->contact_base_m);
      t += "\n  reach margin:   " + m(contact->reach_margin_m);
    }
    return t;
  }
  if (const auto* status = r.get<protocol::Status>()) return status_text(*status);
  if (r.get<protocol::Pong>()) return cmd + ": pong";
  if (const auto* w = r.get<protocol::Welcome>()) {
    return cmd + ": welcome, role " + std::string(protocol::to_string(w->granted_role)) +
           ", daemon " + std::string(w->daemon_version.view());
  }
  return cmd + ": " + std::string(protocol::to_string(protocol::type_of(r.reply)));
}

JsonObject event_object(const protocol::Event& e) {
  JsonObject o;
  o.add("type", "event")
      .add("kind", protocol::to_string(e.kind))
      .add("state", state_name(e.state))
      .add("fault", ajar::to_string(e.fault))
      .add("daemon_time_ns", e.daemon_time_ns)
      .add("detail", e.detail.view());
  return o;
}

std::string event_text(const protocol::Event& e) {
  std::string t =
      "event " + std::string(protocol::to_string(e.kind)) + ": state " + state_name(e.state);
  if (e.fault != ErrorCode::kOk) t += ", fault " + std::string(ajar::to_string(e.fault));
  if (e.detail.length > 0) t += ": " + std::string(e.detail.view());
  return t;
}

JsonObject telemetry_object(const protocol::Telemetry& tm) {
  JsonObject o;
  o.add("type", "telemetry")
      .add("daemon_time_ns", tm.daemon_time_ns)
      .add("state", state_name(tm.state))
      .add("moving", tm.moving)
      .add("wheel_angle_rad", left_right(tm.left_wheel_rad, tm.right_wheel_rad))
      .add("wheel_counts", left_right(tm.left_counts, tm.right_counts))
      .add("base_yaw_odometry_rad", tm.base_yaw_odometry_rad)
      .add("arm_state", protocol::to_string(tm.arm_state))
      .add("loop", loop_object(tm.loop));
  return o;
}

std::string telemetry_text(const protocol::Telemetry& tm) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer,
                "t=%.3f s %s%s wheels L %+.5f R %+.5f rad (%lld / %lld counts) yaw %+.5f rad, "
                "loop %.0f Hz p99 jitter %u ns",
                static_cast<double>(tm.daemon_time_ns) * 1e-9, state_name(tm.state).c_str(),
                tm.moving ? " moving" : "", tm.left_wheel_rad, tm.right_wheel_rad,
                static_cast<long long>(tm.left_counts), static_cast<long long>(tm.right_counts),
                tm.base_yaw_odometry_rad, static_cast<double>(tm.loop.rate_hz),
                tm.loop.jitter_p99_ns);
  return buffer;
}

}  // namespace ajar::client
