// Every kind of ajarctl --json object, rendered from fixed inputs with odd values (negative,
// integral doubles, 1/3, huge and tiny magnitudes, NaN, escapes, UTF-8). json_golden.jsonl holds
// what the hand-written writer printed for these before nlohmann-json replaced it (one line each,
// in this order); json_test.cpp proves the output still has the same keys, order and values.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "ajar/client/output.hpp"

namespace ajar::client::json_samples {

inline constexpr double kThird = 1.0 / 3.0;

inline Response reply_with(protocol::Message message) {
  Response r;
  r.outcome = CallOutcome::kReply;
  r.request_id = 4242;
  r.session_minor = 1;  // a 1.1 session ("status 1.2" below: a 1.2 one)
  r.reply = std::move(message);
  return r;
}

inline protocol::Ack ack(protocol::MessageType acknowledged, protocol::ProcedureState state) {
  protocol::Ack a;
  a.acknowledged = acknowledged;
  a.state = state;
  return a;
}

inline protocol::SpanAck span(double length_m) {
  protocol::SpanAck s;
  s.length_m = length_m;
  s.direction = core::RotationDirection::kCounterClockwise;
  s.p1_base_m = core::Vec3(1.21, -0.43, 0.0);
  s.p2_base_m = core::Vec3(1.0, kThird, 1e-300);
  return s;
}

inline protocol::PlaneAck plane() {
  protocol::PlaneAck p;
  p.yaw_deviation_rad = -0.0277305606204600;
  p.normal = core::Vec3(-1.0, 0.0277, -0.0);
  p.left_wheel_rad = 0.0693;
  p.right_wheel_rad = -0.0693;
  p.left_counts = 5517;
  p.right_counts = -5517;
  p.residual_yaw_rad = 2.5e-7;
  p.rms_residual_m = 0.0;
  p.point_count = 4;
  return p;
}

inline protocol::ContactAck contact() {
  protocol::ContactAck c;
  c.contact_base_m = core::Vec3(0.8, -0.01, 0.3);
  c.reach_margin_m = 0.4;
  return c;
}

template <typename Block>
void fill_motion(Block& m) {
  m.odometry_x_m = 0.5;
  m.odometry_y_m = -0.25;
  m.door.has_distance = true;
  m.door.distance_m = 1.25;
  m.door.has_yaw = true;
  m.door.yaw_rad = -kThird;
  m.staleness.plane = true;
  m.staleness.travel_since_plane_m = 0.31;
  m.commanded_linear_m_s = 0.2;
  m.commanded_angular_rad_s = std::numeric_limits<double>::quiet_NaN();
  m.timing.window_s = 1.5f;
  m.timing.all.samples = 123456;
  m.timing.all.latency.p99_ns = 12345;
  m.timing.all.execution.max_ns = 4000000000u;
  m.timing.recent.samples = 500;
  m.timing.recent.period.p50_ns = 1000000;
  m.loop.rate_hz = 1000.0f;
  m.loop.cycles = 18446744073709551615u;
  m.loop.overruns = 3;
  m.loop.period_p99_ns = 1000123;
  m.loop.jitter_p99_ns = 77;
}

inline protocol::Status status() {
  protocol::Status s;
  s.state = protocol::ProcedureState::kEngaged;
  s.latched_fault = ErrorCode::kDeadman;
  s.restored_from_disk = true;
  s.controller_connected = true;
  s.session_count = 2;
  s.has_width = true;
  s.width = span(0.9);
  s.has_handle = true;
  s.handle = span(0.12);
  s.has_plane = true;
  s.plane = plane();
  s.has_contact = true;
  s.contact = contact();
  s.base_yaw_odometry_rad = 0.25;
  s.realtime.policy = protocol::SchedulingPolicy::kFifo;
  s.realtime.priority = 80;
  s.realtime.memory_locked = true;
  fill_motion(s);
  return s;
}

// Status.recorder (1.2): every field a different value.
inline protocol::RecorderState recorder() {
  protocol::RecorderState r;
  r.enabled = true;
  r.mode = protocol::RecorderMode::kDiskFull;
  r.file = "ajard-20261126T130501123Z.mcap";
  r.file_bytes = 123456;
  r.directory_bytes = 98765432;
  r.max_bytes = 536870912;
  r.saved_bytes = 4096;
  r.disk_free_bytes = 18446744073709551615u;
  r.records_written = 1000;
  r.loop_samples = 900;
  r.loop_dropped = 12;
  r.io_records = 300;
  r.io_dropped = 3;
  r.records_lost = 7;
  r.disk_refusals = 2;
  r.last_write_ns = 5000000001;
  return r;
}

inline protocol::RobotModel robot_model() {
  protocol::RobotModel m;
  m.camera_to_base = {0, 0, 1, 0.15, -1, 0, 0, 0.015, 0, -1, 0, -0.22};
  m.left.card_axis = 1;
  m.left.polarity = 1;
  m.right.card_axis = 2;
  m.right.polarity = -1;
  m.arm_shoulder_m = core::Vec3(0.1, 0.0, 0.45);
  m.wheel_radius_m = 0.1;
  m.encoder_counts_per_rev = 10000;
  m.gear_ratio = 50;
  m.max_wheel_accel_rad_s2 = 6.02214076e23;
  m.drive_command_timeout_s = 0.5;
  m.collinearity = kThird;
  return m;
}

inline protocol::Welcome welcome() {
  protocol::Welcome w;
  w.version_minor = 1;  // the golden line is a 1.1 daemon's Welcome
  w.granted_role = protocol::Role::kController;
  w.session_id = 9007199254740993u;  // 2^53 + 1: exact only as an integer
  w.daemon_version = "0.1.0 \"dev\" \xc3\xa9";
  w.loop_rate_hz = 1000.0f;
  w.deadman_timeout_s = 0.3f;
  w.min_door_width_m = 0.7f;
  w.max_door_width_m = 1.2f;
  w.min_handle_length_m = 0.05f;
  w.max_handle_length_m = 0.3f;
  w.max_yaw_correction_rad = 0.35f;
  w.driver_kind = protocol::DriverKind::kReal;
  return w;
}

using NamedObjects = std::vector<std::pair<std::string, JsonObject>>;

inline void add_sample(NamedObjects& out, std::string name, JsonObject o) {
  out.emplace_back(std::move(name), std::move(o));
}

// The replies: every Ack body, Status, RobotModel, Pong, Welcome and any other reply.
inline void add_replies(NamedObjects& out) {
  using protocol::MessageType;
  using protocol::ProcedureState;
  auto a = ack(MessageType::kMeasureDoorWidth, ProcedureState::kAwaitingHandle);
  a.body = span(0.9152);
  add_sample(out, "ack width", response_object("measure_width", reply_with(a)));
  a = ack(MessageType::kMeasureHandle, ProcedureState::kAwaitingPlane);
  a.body = span(0.12);
  add_sample(out, "ack handle", response_object("measure_handle", reply_with(a)));
  a = ack(MessageType::kMeasureDoorPlane, ProcedureState::kReadyToAlign);
  a.body = plane();
  add_sample(out, "ack plane", response_object("measure_plane", reply_with(a)));
  a = ack(MessageType::kSetContactPoint, ProcedureState::kReadyToEngage);
  a.body = contact();
  add_sample(out, "ack contact", response_object("contact", reply_with(a)));
  a = ack(MessageType::kApproach, ProcedureState::kAwaitingWidth);
  protocol::ApproachAck approach;
  approach.travel_m = 0.25;
  approach.start_distance_m = 1.0;
  approach.left_counts = 198944;
  approach.right_counts = -198944;
  a.body = approach;
  add_sample(out, "ack approach", response_object("approach", reply_with(a)));
  add_sample(out, "ack reset",
             response_object("reset",
                             reply_with(ack(MessageType::kReset, ProcedureState::kAwaitingWidth))));
  add_sample(out, "status", response_object("status", reply_with(status())));
  add_sample(out, "status empty", response_object("status", reply_with(protocol::Status{})));
  add_sample(out, "robot model", response_object("model", reply_with(robot_model())));
  protocol::Pong pong;
  pong.daemon_time_ns = 1234567890123456789u;
  add_sample(out, "pong", response_object("ping", reply_with(pong)));
  add_sample(out, "welcome", response_object("hello", reply_with(welcome())));
  add_sample(out, "other reply", response_object("stop", reply_with(protocol::Stop{})));
}

// A request without a reply: refused, timed out, disconnected.
inline void add_failures(NamedObjects& out) {
  Response refused;
  refused.outcome = CallOutcome::kRefused;
  refused.request_id = 7;
  refused.error.code = ErrorCode::kPointsCollinear;
  refused.error.field = "points[2]";
  refused.error.message = "the points are \"in a row\"\\\n\t\x01 (\xc2\xb0)";
  add_sample(out, "refused", response_object("measure_plane", refused));
  Response timeout;
  timeout.outcome = CallOutcome::kTimeout;
  timeout.transport_error = "no reply in 2.0 s";
  add_sample(out, "timeout", response_object("status", timeout));
  Response disconnected;
  disconnected.outcome = CallOutcome::kDisconnected;
  disconnected.transport_error = "connection reset";
  add_sample(out, "disconnected", response_object("status", disconnected));
}

// What is not a reply: an event, telemetry, the Welcome and error objects, a 1.2 Status.
inline void add_other_objects(NamedObjects& out) {
  using protocol::ProcedureState;
  protocol::Event e;
  e.kind = protocol::EventKind::kFaultLatched;
  e.state = ProcedureState::kFault;
  e.fault = ErrorCode::kDeadman;
  e.daemon_time_ns = 42;
  e.detail = "controller \"gui\" went silent";
  add_sample(out, "event", event_object(e));

  protocol::Telemetry t;
  t.daemon_time_ns = 1000000000;
  t.state = ProcedureState::kAligning;
  t.moving = true;
  t.left_wheel_rad = -0.5;
  t.right_wheel_rad = 0.5;
  t.left_counts = -100;
  t.right_counts = 100;
  t.base_yaw_odometry_rad = -std::numeric_limits<double>::infinity();
  fill_motion(t);
  add_sample(out, "telemetry", telemetry_object(t));
  add_sample(out, "telemetry empty", telemetry_object(protocol::Telemetry{}));
  add_sample(out, "welcome object", welcome_object(welcome()));
  add_sample(out, "error object", error_object("SIMULATION_FAILED", "", "x \x7f y"));
  Response status_1_2 = reply_with(status());  // a 1.2 session: base_motion and the recorder
  status_1_2.session_minor = 2;
  std::get<protocol::Status>(status_1_2.reply).base_motion = protocol::BaseMotion::kStopping;
  std::get<protocol::Status>(status_1_2.reply).recorder = recorder();
  add_sample(out, "status 1.2", response_object("status", status_1_2));
}

// (name, object) in the order of json_golden.jsonl.
inline NamedObjects all() {
  NamedObjects out;
  add_replies(out);
  add_failures(out);
  add_other_objects(out);
  return out;
}

}  // namespace ajar::client::json_samples
