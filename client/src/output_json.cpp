// ajarctl's --json renderings (output.hpp): the objects, field by field, under the names of
// docs/ajarctl.md.
#include "ajar/client/output.hpp"
#include "output_fields.hpp"

namespace ajar::client {
namespace {

using output::state_name;

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

// [lo, hi]
JsonArray range(float lo, float hi) {
  JsonArray a;
  a.add(static_cast<double>(lo)).add(static_cast<double>(hi));
  return a;
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

JsonObject wheel_object(const protocol::WheelModel& w) {
  JsonObject o;
  o.add("card_axis", static_cast<unsigned>(w.card_axis)).add("polarity", int{w.polarity});
  return o;
}

}  // namespace

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

JsonObject recorder_object(const protocol::RecorderState& r) {
  JsonObject o;
  o.add("enabled", r.enabled)
      .add("mode", protocol::to_string(r.mode))
      .add("file", r.file.view())
      .add("file_bytes", r.file_bytes)
      .add("directory_bytes", r.directory_bytes)
      .add("max_bytes", r.max_bytes)
      .add("saved_bytes", r.saved_bytes)
      .add("disk_free_bytes", r.disk_free_bytes)
      .add("records_written", r.records_written)
      .add("loop_samples", r.loop_samples)
      .add("loop_dropped", r.loop_dropped)
      .add("io_records", r.io_records)
      .add("io_dropped", r.io_dropped)
      .add("records_lost", r.records_lost)
      .add("disk_refusals", r.disk_refusals)
      .add("last_write_ns", r.last_write_ns);
  return o;
}

JsonObject status_object(const protocol::Status& s, std::uint8_t session_minor) {
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
  if (session_minor >= 2) {
    o.add("base_motion", protocol::to_string(s.base_motion));
    o.add("recorder", recorder_object(s.recorder));
  }
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
      .add("door_width_m", range(w.min_door_width_m, w.max_door_width_m))
      .add("handle_length_m", range(w.min_handle_length_m, w.max_handle_length_m))
      .add("max_yaw_correction_rad", w.max_yaw_correction_rad)
      .add("driver_kind", protocol::to_string(w.driver_kind));
  return o;
}

JsonObject robot_model_object(const protocol::RobotModel& model) {
  JsonObject o;
  JsonArray rows;
  for (std::size_t r = 0; r < 3; ++r) {
    JsonArray row;
    for (std::size_t c = 0; c < 4; ++c)
      row.add(model.camera_to_base[r * 4 + c]);
    rows.add(row);
  }
  o.add("camera_to_base", rows);
  o.add("left", wheel_object(model.left)).add("right", wheel_object(model.right));
  o.add("arm_shoulder_m", model.arm_shoulder_m);
  for (const auto& f : output::kModelFields)
    o.add(f.name, model.*f.member);
  return o;
}

JsonObject response_object(std::string_view command, const Response& r) {
  JsonObject o;
  switch (r.outcome) {
    case CallOutcome::kTimeout:
    case CallOutcome::kDisconnected:
      o.add("type", "error").add("command", command).add("ok", false);
      o.add("error",
            error_object(r.outcome == CallOutcome::kTimeout ? kTimeoutCode : kDisconnectedCode, "",
                         r.transport_error));
      return o;
    case CallOutcome::kRefused:
      o.add("type", "error").add("command", command).add("ok", false);
      o.add("request_id", static_cast<unsigned>(r.request_id));
      o.add("error", error_object(r.error));
      return o;
    case CallOutcome::kReply:
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
    o.add("status", status_object(*status, r.session_minor));
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

}  // namespace ajar::client
