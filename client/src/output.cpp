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

std::string m_text(double v) {
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

std::string pad_key(std::string_view key) {
  std::string t(key);
  t += ':';
  if (t.size() < 32) t.append(32 - t.size(), ' ');
  return t;
}

JsonObject quantiles_object(const protocol::Quantiles& q) {
  JsonObject o;
  o.add("p50_ns", static_cast<std::uint64_t>(q.p50_ns))
      .add("p99_ns", static_cast<std::uint64_t>(q.p99_ns))
      .add("p999_ns", static_cast<std::uint64_t>(q.p999_ns))
      .add("max_ns", static_cast<std::uint64_t>(q.max_ns));
  return o;
}

JsonObject timing_window_object(const protocol::TimingWindow& w) {
  JsonObject o;
  o.add("samples", w.samples)
      .add("latency", quantiles_object(w.latency))
      .add("execution", quantiles_object(w.execution))
      .add("period", quantiles_object(w.period));
  return o;
}

JsonObject timing_object(const protocol::LoopTiming& t) {
  JsonObject o;
  o.add("window_s", t.window_s)
      .add("all", timing_window_object(t.all))
      .add("recent", timing_window_object(t.recent));
  return o;
}

// The fields protocol 1.1 appended to both Status and Telemetry (the MotionBlock), under their wire
// names: one rendering for both.
template <typename T>
void add_motion_fields(JsonObject& o, const T& m) {
  o.add("odometry_x_m", m.odometry_x_m).add("odometry_y_m", m.odometry_y_m);
  JsonObject door;  // each value only when known
  if (m.door.has_distance) door.add("distance_m", m.door.distance_m);
  if (m.door.has_yaw) door.add("yaw_rad", m.door.yaw_rad);
  o.add("door", door);
  JsonObject stale;
  stale.add("plane", m.staleness.plane)
      .add("contact", m.staleness.contact)
      .add("travel_since_plane_m", m.staleness.travel_since_plane_m);
  o.add("staleness", stale);
  o.add("commanded_linear_m_s", m.commanded_linear_m_s)
      .add("commanded_angular_rad_s", m.commanded_angular_rad_s)
      .add("timing", timing_object(m.timing));
}

std::string us(std::uint32_t ns) {
  return fixed(static_cast<double>(ns) * 1e-3, 1) + " us";
}

// Text of the MotionBlock, one line each (status) or compact (telemetry).
template <typename T>
std::string door_text(const T& m) {
  if (!m.door.has_distance) return "unknown";
  std::string t = m_text(m.door.distance_m) + " to the door";
  if (m.door.has_yaw) t += ", yaw to correct " + rad(m.door.yaw_rad);
  return t;
}

template <typename T>
std::string stale_text(const T& m) {
  std::string t;
  if (m.staleness.plane) t += "plane";
  if (m.staleness.contact) t += t.empty() ? "contact" : ", contact";
  if (t.empty()) t = "nothing";
  return t;
}

std::string window_text(const protocol::TimingWindow& w) {
  return "latency p99 " + us(w.latency.p99_ns) + " (max " + us(w.latency.max_ns) +
         "), execution p99 " + us(w.execution.p99_ns) + " (max " + us(w.execution.max_ns) +
         "), period p99 " + us(w.period.p99_ns) + ", " + std::to_string(w.samples) + " cycles";
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

void add_approach_fields(JsonObject& o, const protocol::ApproachAck& approach) {
  o.add("travel_m", approach.travel_m)
      .add("start_distance_m", approach.start_distance_m)
      .add("wheel_counts", left_right(approach.left_counts, approach.right_counts));
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
  add_motion_fields(o, s);
  JsonObject rt;
  rt.add("policy", protocol::to_string(s.realtime.policy))
      .add("priority", static_cast<unsigned>(s.realtime.priority))
      .add("memory_locked", s.realtime.memory_locked);
  o.add("realtime", rt);
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
      .add("max_yaw_correction_rad", w.max_yaw_correction_rad)
      .add("driver_kind", protocol::to_string(w.driver_kind));
  return o;
}

namespace {

// RobotModel's scalar fields under their wire names (docs/protocol.md 5.22): the JSON keys and the
// text lines both come from this table.
struct ModelField {
  std::string_view name;
  double protocol::RobotModel::*member;
};
constexpr ModelField kModelFields[] = {
    {"wheel_radius_m", &protocol::RobotModel::wheel_radius_m},
    {"turning_radius_m", &protocol::RobotModel::turning_radius_m},
    {"encoder_counts_per_rev", &protocol::RobotModel::encoder_counts_per_rev},
    {"gear_ratio", &protocol::RobotModel::gear_ratio},
    {"max_wheel_speed_rad_s", &protocol::RobotModel::max_wheel_speed_rad_s},
    {"max_wheel_accel_rad_s2", &protocol::RobotModel::max_wheel_accel_rad_s2},
    {"max_linear_speed_m_s", &protocol::RobotModel::max_linear_speed_m_s},
    {"max_angular_speed_rad_s", &protocol::RobotModel::max_angular_speed_rad_s},
    {"max_linear_accel_m_s2", &protocol::RobotModel::max_linear_accel_m_s2},
    {"max_angular_accel_rad_s2", &protocol::RobotModel::max_angular_accel_rad_s2},
    {"drive_command_timeout_s", &protocol::RobotModel::drive_command_timeout_s},
    {"approach_max_travel_m", &protocol::RobotModel::approach_max_travel_m},
    {"approach_square_tolerance_rad", &protocol::RobotModel::approach_square_tolerance_rad},
    {"approach_min_standoff_m", &protocol::RobotModel::approach_min_standoff_m},
    {"stale_travel_m", &protocol::RobotModel::stale_travel_m},
    {"stale_yaw_rad", &protocol::RobotModel::stale_yaw_rad},
    {"arm_min_reach_m", &protocol::RobotModel::arm_min_reach_m},
    {"arm_max_reach_m", &protocol::RobotModel::arm_max_reach_m},
    {"arm_min_z_m", &protocol::RobotModel::arm_min_z_m},
    {"arm_max_z_m", &protocol::RobotModel::arm_max_z_m},
    {"min_depth_m", &protocol::RobotModel::min_depth_m},
    {"max_depth_m", &protocol::RobotModel::max_depth_m},
    {"min_door_width_m", &protocol::RobotModel::min_door_width_m},
    {"max_door_width_m", &protocol::RobotModel::max_door_width_m},
    {"min_handle_length_m", &protocol::RobotModel::min_handle_length_m},
    {"max_handle_length_m", &protocol::RobotModel::max_handle_length_m},
    {"max_yaw_correction_rad", &protocol::RobotModel::max_yaw_correction_rad},
    {"aligned_tolerance_rad", &protocol::RobotModel::aligned_tolerance_rad},
    {"min_point_separation_m", &protocol::RobotModel::min_point_separation_m},
    {"min_lateral_fraction", &protocol::RobotModel::min_lateral_fraction},
    {"collinearity", &protocol::RobotModel::collinearity},
    {"max_plane_rms_m", &protocol::RobotModel::max_plane_rms_m},
    {"max_door_tilt_rad", &protocol::RobotModel::max_door_tilt_rad},
};

JsonObject wheel_object(const protocol::WheelModel& w) {
  JsonObject o;
  o.add("card_axis", static_cast<unsigned>(w.card_axis)).add("polarity", int{w.polarity});
  return o;
}

}  // namespace

JsonObject robot_model_object(const protocol::RobotModel& model) {
  JsonObject o;
  std::string rows = "[";
  for (std::size_t r = 0; r < 3; ++r) {
    rows += r == 0 ? "[" : ", [";
    for (std::size_t c = 0; c < 4; ++c) {
      if (c > 0) rows += ", ";
      rows += json_number(model.camera_to_base[r * 4 + c]);
    }
    rows += "]";
  }
  rows += "]";
  o.add_raw("camera_to_base", rows);
  o.add("left", wheel_object(model.left)).add("right", wheel_object(model.right));
  o.add("arm_shoulder_m", model.arm_shoulder_m);
  for (const auto& f : kModelFields)
    o.add(f.name, model.*f.member);
  return o;
}

std::string robot_model_text(const protocol::RobotModel& model) {
  std::string t = "camera_to_base (rows of [R | t]):\n";
  for (std::size_t r = 0; r < 3; ++r) {
    t += "  ";
    for (std::size_t c = 0; c < 4; ++c) {
      t += ' ';
      t += fixed(model.camera_to_base[r * 4 + c], 6, true);
    }
    t += "\n";
  }
  auto wheel = [](const protocol::WheelModel& w) {
    return "card axis " + std::to_string(w.card_axis) + ", polarity " +
           (w.polarity > 0 ? std::string("+1") : std::string("-1"));
  };
  t += pad_key("left wheel") + wheel(model.left) + "\n";
  t += pad_key("right wheel") + wheel(model.right) + "\n";
  t += pad_key("arm_shoulder_m") + vec(model.arm_shoulder_m) + "\n";
  for (const auto& f : kModelFields) {
    char value[64];
    std::snprintf(value, sizeof value, "%.10g", model.*f.member);
    t += pad_key(f.name) + value + "\n";
  }
  t.pop_back();
  return t;
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
    } else if (const auto* approach = std::get_if<protocol::ApproachAck>(&ack->body)) {
      add_approach_fields(o, *approach);
    }
  } else if (const auto* model = r.get<protocol::RobotModel>()) {
    o.add("type", "robot_model").add("command", command).add("ok", true);
    o.add("robot_model", robot_model_object(*model));
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
    t += "door width:       " + m_text(s.width.length_m) + ", " +
         core::to_string(s.width.direction) + "\n";
  }
  if (s.has_handle) {
    t += "handle length:    " + m_text(s.handle.length_m) + ", " +
         core::to_string(s.handle.direction) + "\n";
  }
  if (s.has_plane) {
    t += "yaw deviation:    " + rad(s.plane.yaw_deviation_rad) + " from " +
         std::to_string(s.plane.point_count) + " points\n";
  }
  if (s.has_contact) t += "contact (base):   " + vec(s.contact.contact_base_m) + "\n";
  t += "odometry:         x " + fixed(s.odometry_x_m, 4, true) + " m, y " +
       fixed(s.odometry_y_m, 4, true) + " m, yaw " + rad(s.base_yaw_odometry_rad) + "\n";
  t += "door:             " + door_text(s) + "\n";
  t += "stale:            " + stale_text(s);
  if (s.has_plane)
    t += " (base moved " + m_text(s.staleness.travel_since_plane_m) + " since the plane)";
  t += "\n";
  t += "commanded:        " + fixed(s.commanded_linear_m_s, 3, true) + " m/s, " +
       fixed(s.commanded_angular_rad_s, 4, true) + " rad/s\n";
  t += "card / arm:       " + std::string(protocol::to_string(s.card)) + " / " +
       std::string(protocol::to_string(s.arm)) + " (" +
       std::string(protocol::to_string(s.arm_state)) + ")\n";
  t += "loop:             " + fixed(static_cast<double>(s.loop.rate_hz), 0) + " Hz, " +
       std::to_string(s.loop.cycles) + " cycles, " + std::to_string(s.loop.overruns) +
       " overruns; " + std::string(protocol::to_string(s.realtime.policy)) + " priority " +
       std::to_string(s.realtime.priority) +
       (s.realtime.memory_locked ? ", memory locked" : ", memory not locked") + "\n";
  t += "timing, recent:   (last " + fixed(static_cast<double>(s.timing.window_s), 1) + " s) " +
       window_text(s.timing.recent) + "\n";
  t += "timing, all:      " + window_text(s.timing.all);
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
      t += m_text(span->length_m) + ", direction " + core::to_string(span->direction);
      t += "\n  p1 (base):     " + vec(span->p1_base_m);
      t += "\n  p2 (base):     " + vec(span->p2_base_m);
    } else if (const auto* plane = std::get_if<protocol::PlaneAck>(&ack->body)) {
      t += "\n  yaw deviation: " + rad(plane->yaw_deviation_rad);
      t += "\n  wheel angles:  left " + fixed(plane->left_wheel_rad, 5, true) + " rad, right " +
           fixed(plane->right_wheel_rad, 5, true) + " rad";
      t += "\n  wheel counts:  left " + std::to_string(plane->left_counts) + ", right " +
           std::to_string(plane->right_counts);
      t += "\n  plane fit:     " + std::to_string(plane->point_count) + " points, rms " +
           m_text(plane->rms_residual_m);
    } else if (const auto* contact = std::get_if<protocol::ContactAck>(&ack->body)) {
      t += "\n  contact (base): " + vec(contact->contact_base_m);
      t += "\n  reach margin:   " + m_text(contact->reach_margin_m);
    } else if (const auto* approach = std::get_if<protocol::ApproachAck>(&ack->body)) {
      t += "\n  travel:        " + fixed(approach->travel_m, 4, true) + " m (door now " +
           m_text(approach->start_distance_m) + " away)";
      t += "\n  wheel counts:  left " + std::to_string(approach->left_counts) + ", right " +
           std::to_string(approach->right_counts);
    }
    return t;
  }
  if (const auto* model = r.get<protocol::RobotModel>()) return robot_model_text(*model);
  if (const auto* status = r.get<protocol::Status>()) return status_text(*status);
  if (r.get<protocol::Pong>()) return cmd + ": pong";
  if (const auto* w = r.get<protocol::Welcome>()) {
    return cmd + ": welcome, role " + std::string(protocol::to_string(w->granted_role)) +
           ", daemon " + std::string(w->daemon_version.view()) + ", drivers " +
           std::string(protocol::to_string(w->driver_kind));
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
  add_motion_fields(o, tm);
  return o;
}

std::string telemetry_text(const protocol::Telemetry& tm) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer,
                "t=%.3f s %s%s odometry x %+.4f y %+.4f m yaw %+.5f rad, wheels L %+.5f R %+.5f "
                "rad (%lld / %lld counts), commanded %+.3f m/s %+.4f rad/s",
                static_cast<double>(tm.daemon_time_ns) * 1e-9, state_name(tm.state).c_str(),
                tm.moving ? " moving" : "", tm.odometry_x_m, tm.odometry_y_m,
                tm.base_yaw_odometry_rad, tm.left_wheel_rad, tm.right_wheel_rad,
                static_cast<long long>(tm.left_counts), static_cast<long long>(tm.right_counts),
                tm.commanded_linear_m_s, tm.commanded_angular_rad_s);
  std::string t = buffer;
  if (tm.door.has_distance) {
    t += ", door " + m_text(tm.door.distance_m);
    if (tm.door.has_yaw) t += " yaw " + fixed(tm.door.yaw_rad, 5, true) + " rad";
  }
  if (tm.staleness.plane || tm.staleness.contact) t += ", STALE " + stale_text(tm);
  t += ", loop " + fixed(static_cast<double>(tm.loop.rate_hz), 0) + " Hz latency p99 " +
       us(tm.timing.recent.latency.p99_ns) + " exec p99 " + us(tm.timing.recent.execution.p99_ns);
  return t;
}

}  // namespace ajar::client
