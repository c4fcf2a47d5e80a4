#include "daemon_json.hpp"

#include <cstdint>

#include "ajar/client/json.hpp"
#include "ajar/client/output.hpp"

namespace ajar::console {
namespace {

using client::JsonObject;

JsonObject span_json(const protocol::SpanAck& a) {
  return JsonObject()
      .add("length_m", a.length_m)
      .add("direction", core::to_string(a.direction))
      .add("p1_base_m", a.p1_base_m)
      .add("p2_base_m", a.p2_base_m);
}
JsonObject plane_json(const protocol::PlaneAck& a) {
  return JsonObject()
      .add("normal", a.normal)
      .add("yaw_deviation_rad", a.yaw_deviation_rad)
      .add("left_wheel_rad", a.left_wheel_rad)
      .add("right_wheel_rad", a.right_wheel_rad)
      .add("left_counts", static_cast<std::int64_t>(a.left_counts))
      .add("right_counts", static_cast<std::int64_t>(a.right_counts))
      .add("residual_yaw_rad", a.residual_yaw_rad)
      .add("rms_residual_m", a.rms_residual_m)
      .add("point_count", static_cast<int>(a.point_count));
}
JsonObject contact_json(const protocol::ContactAck& a) {
  return JsonObject()
      .add("contact_base_m", a.contact_base_m)
      .add("reach_margin_m", a.reach_margin_m);
}

}  // namespace

JsonObject response_json(const client::Response& r) {
  JsonObject o;
  if (r.outcome == client::CallOutcome::kReply) {
    o.add("ok", true);
    if (const auto* ack = r.get<protocol::Ack>()) {
      o.add("state", protocol::to_string(ack->state));
      if (const auto* s = std::get_if<protocol::SpanAck>(&ack->body))
        o.add("values", span_json(*s));
      if (const auto* p = std::get_if<protocol::PlaneAck>(&ack->body))
        o.add("values", plane_json(*p));
      if (const auto* c = std::get_if<protocol::ContactAck>(&ack->body)) {
        o.add("values", contact_json(*c));
      }
    }
    return o;
  }
  o.add("ok", false);
  if (r.outcome == client::CallOutcome::kRefused) {
    o.add("code", ajar::to_string(r.error.code));
    o.add("field", r.error.field.view());
    o.add("message", r.error.message.view());
  } else {
    o.add("code", client::to_string(r.outcome));
    o.add("field", "");
    o.add("message", r.transport_error);
  }
  return o;
}

JsonObject status_json(const protocol::Status& s) {
  JsonObject o;
  o.add("state", protocol::to_string(s.state));
  o.add("latched_fault", ajar::to_string(s.latched_fault));
  o.add("controller_connected", s.controller_connected);
  o.add("session_count", static_cast<int>(s.session_count));
  o.add("restored_from_disk", s.restored_from_disk);
  if (s.has_width) o.add("width", span_json(s.width));
  if (s.has_handle) o.add("handle", span_json(s.handle));
  if (s.has_plane) o.add("plane", plane_json(s.plane));
  if (s.has_contact) o.add("contact", contact_json(s.contact));
  o.add("base_yaw_odometry_rad", s.base_yaw_odometry_rad);
  o.add("card", protocol::to_string(s.card));
  o.add("arm", protocol::to_string(s.arm));
  o.add("arm_state", protocol::to_string(s.arm_state));
  o.add("loop", client::loop_object(s.loop));
  return o;
}

JsonObject telemetry_json(const protocol::Telemetry& t) {
  return JsonObject()
      .add("type", "telemetry")
      .add("t_s", static_cast<double>(t.daemon_time_ns) * 1e-9)
      .add("state", protocol::to_string(t.state))
      .add("moving", t.moving)
      .add("left_wheel_rad", t.left_wheel_rad)
      .add("right_wheel_rad", t.right_wheel_rad)
      .add("left_counts", static_cast<std::int64_t>(t.left_counts))
      .add("right_counts", static_cast<std::int64_t>(t.right_counts))
      .add("base_yaw_odometry_rad", t.base_yaw_odometry_rad)
      .add("odometry_x_m", t.odometry_x_m)
      .add("odometry_y_m", t.odometry_y_m)
      .add("door_has_distance", t.door.has_distance)
      .add("door_distance_m", t.door.distance_m)
      .add("door_has_yaw", t.door.has_yaw)
      .add("door_yaw_rad", t.door.yaw_rad)
      .add("plane_stale", t.staleness.plane)
      .add("contact_stale", t.staleness.contact)
      .add("commanded_linear_m_s", t.commanded_linear_m_s)
      .add("commanded_angular_rad_s", t.commanded_angular_rad_s)
      .add("arm_state", protocol::to_string(t.arm_state))
      .add("loop", client::loop_object(t.loop));
}

}  // namespace ajar::console
