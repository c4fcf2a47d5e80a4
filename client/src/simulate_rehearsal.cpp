// ajarctl simulate's rehearsal, the procedure itself (simulate_rehearsal.hpp): connect as the
// controller, Reset, then (driving scenarios) jog, measure the width from afar and Approach; width,
// handle, plane, Align until aligned, contact, Engage; every answer checked against the world.
#include "simulate_rehearsal.hpp"

#include <cmath>
#include <numbers>
#include <thread>

#include "ajar/client/cli.hpp"
#include "ajar/client/output.hpp"

namespace ajar::client::simulation {

RunResult Rehearsal::run() {
  result_.seed = scenario_.seed;
  result_.expected_direction = world_.expected_ccw() ? "CCW" : "CW";
  result_.true_width_m = scenario_.door_width_m - 2 * scenario_.edge_inset_m;
  result_.true_handle_m = scenario_.handle_length_m;
  Client client(client_options());
  client_ = &client;
  client.on_telemetry([this](const protocol::Telemetry& t) { on_telemetry(t); });
  if (!start_session()) return result_;

  // 0. Fig. 4 from afar: jog toward the door, measure the width, Approach to the width standoff.
  if (scenario_.drive && !approach_from_afar()) return result_;
  // 1. Door width.
  if (!measure_width("measure_width")) return result_;
  if (scenario_.drive && !approach(scenario_.handle_standoff_m, "approach_handle")) {
    return result_;
  }
  // 2. Handle. 3. Plane. 4. Align until kept. 5. Contact point. 6. Engage.
  if (!measure_handle() || !measure_first_plane() || !align_until_kept() || !set_contact_point() ||
      !engage()) {
    return result_;
  }
  if (scenario_.drive) result_.final_standoff_m = world_.true_distance_m(pose_);
  recording_ = false;
  (void)client.request(protocol::Subscribe{});
  result_.completed = true;
  check_tolerances();
  return result_;
}

ClientOptions Rehearsal::client_options() const {
  ClientOptions co;
  co.request_timeout = Milliseconds{static_cast<std::int64_t>(options_.timeout_s * 1000)};
  co.retries = options_.retries;
  co.tls = options_.tls;
  co.client_name = "ajarctl simulate";
  return co;
}

bool Rehearsal::start_session() {
  if (const auto connected = client_->connect(options_.endpoint); !connected) {
    (void)fail("connect: " + connected.error().message, true);
    return false;
  }
  if (!expect_reply("hello", client_->hello(protocol::Role::kController, options_.take_over))) {
    return false;
  }
  const Response model = client_->request(protocol::GetRobotModel{});
  if (const auto* m = model.get<protocol::RobotModel>()) {
    geometry_.wheel_radius_m = m->wheel_radius_m;
    geometry_.turning_radius_m = m->turning_radius_m;
  } else if (noisy()) {
    (void)fail("get_robot_model: " + response_text("get_robot_model", model), false);
    return false;
  }
  start_ = Clock::now();
  protocol::Reset reset;
  reset.clear_parameters = true;
  if (!expect_reply("reset", client_->request(reset))) return false;
  if (!refresh_pose(true)) return false;
  (void)client_->request(protocol::Subscribe{50.0f});
  recording_ = true;
  return true;
}

bool Rehearsal::approach_from_afar() {
  if (scenario_.jog_m > 0 && !jog(scenario_.jog_m, scenario_.jog_speed_m_s)) return false;
  if (!measure_width("measure_width_far")) return false;
  return approach(scenario_.width_standoff_m, "approach_width");
}

bool Rehearsal::measure_handle() {
  if (!refresh_pose(false)) return false;
  protocol::MeasureHandle m;
  m.p1_axis = camera(world_.handle_axis_point());
  m.p2_free_end = camera(world_.handle_free_end_point());
  const Response r = client_->request(m);
  if (!expect_reply("measure_handle", r)) return false;
  const auto& span = std::get<protocol::SpanAck>(r.get<protocol::Ack>()->body);
  result_.measured_handle_m = span.length_m;
  add_row("measure_handle", r, result_.true_handle_m, span.length_m,
          core::to_string(span.direction));
  return true;
}

bool Rehearsal::measure_first_plane() {
  const auto first = measure_plane("measure_plane");
  if (!first) return false;
  result_.yaw_before_true_rad = world_.true_yaw_error_rad(pose_.yaw_rad);
  result_.yaw_before_measured_rad = first->yaw_deviation_rad;
  result_.plane_rms_m = first->rms_residual_m;
  result_.cmd_left_rad = first->left_wheel_rad;
  result_.cmd_right_rad = first->right_wheel_rad;
  result_.cmd_left_counts = first->left_counts;
  result_.cmd_right_counts = first->right_counts;
  return true;
}

bool Rehearsal::align_until_kept() {
  // Encoder angles are reported as the change over the alignment(s) (the encoders count since
  // the daemon started).
  const auto encoders_before = fresh_telemetry();
  bool aligned = false;
  for (int i = 0; i < scenario_.max_align_iterations && !aligned; ++i) {
    ++result_.align_iterations;
    if (!align()) return false;
    const auto again = measure_plane("remeasure_plane");
    if (!again) return false;
    result_.yaw_after_true_rad = world_.true_yaw_error_rad(pose_.yaw_rad);
    result_.yaw_after_measured_rad = again->yaw_deviation_rad;
    aligned = last_state_ == protocol::ProcedureState::kAligned;
  }
  if (!aligned) {
    (void)fail("still not aligned after " + std::to_string(scenario_.max_align_iterations) +
                   " alignment(s)",
               false);
    return false;
  }
  if (const auto encoders_after = fresh_telemetry(); encoders_before && encoders_after) {
    result_.enc_left_rad = encoders_after->left_wheel_rad - encoders_before->left_wheel_rad;
    result_.enc_right_rad = encoders_after->right_wheel_rad - encoders_before->right_wheel_rad;
  }
  return true;
}

bool Rehearsal::set_contact_point() {
  if (!refresh_pose(false)) return false;
  const core::Vec3 truth_world = world_.contact_point();
  protocol::SetContactPoint m;
  m.contact = camera(truth_world);
  const Response r = client_->request(m);
  if (!expect_reply("contact", r)) return false;
  const auto& contact = std::get<protocol::ContactAck>(r.get<protocol::Ack>()->body);
  const core::Vec3 truth_base = core::rebase(truth_world, core::PlanarPose{}, pose_);
  result_.contact_error_m = (contact.contact_base_m - truth_base).norm();
  result_.reach_margin_m = contact.reach_margin_m;
  add_row("contact", r, 0, result_.contact_error_m, "value: contact error (m)");
  return true;
}

bool Rehearsal::engage() {
  const Response r = client_->request(protocol::Engage{});
  if (!expect_reply("engage", r)) return false;
  add_row("engage", r, std::nan(""), std::nan(""), "");
  const auto final_state = wait_while(protocol::ProcedureState::kEngaging, 60.0);
  if (!final_state) return false;
  result_.final_state = std::string(protocol::to_string(*final_state));
  add_state_row("engaged", "");
  if (scenario_.expect_engaged && *final_state != protocol::ProcedureState::kEngaged) {
    (void)fail("engage ended in state " + result_.final_state, false);
    return false;
  }
  return true;
}

bool Rehearsal::measure_width(const std::string& step) {
  if (!refresh_pose(false)) return false;
  protocol::MeasureDoorWidth m;
  m.p1_hinge = camera(world_.hinge_edge_point());
  m.p2_moving_edge = camera(world_.moving_edge_point());
  const Response r = client_->request(m);
  if (!expect_reply(step, r)) return false;
  const auto& span = std::get<protocol::SpanAck>(r.get<protocol::Ack>()->body);
  result_.measured_width_m = span.length_m;
  result_.direction = core::to_string(span.direction);
  add_row(step, r, result_.true_width_m, span.length_m, result_.direction);
  return true;
}

bool Rehearsal::jog(double distance_m, double speed_m_s) {
  if (!refresh_pose(false)) return false;
  const core::PlanarPose from = pose_;
  client_->set_heartbeat(Milliseconds{100});
  const auto deadline =
      Clock::now() +
      Milliseconds{static_cast<std::int64_t>((distance_m / speed_m_s * 3 + 5) * 1e3)};
  bool ok = true;
  while (Clock::now() < deadline) {
    const Response r = client_->request(protocol::Drive{speed_m_s, 0.0});
    if (!expect_reply("drive", r)) {
      ok = false;
      break;
    }
    const Response st = client_->request(protocol::GetStatus{});
    if (!expect_reply("status", st)) {
      ok = false;
      break;
    }
    const core::PlanarPose now = world_pose(odometry_of(*st.get<protocol::Status>()));
    if (core::travel_m(from, now) >= distance_m) break;
    std::this_thread::sleep_for(Milliseconds{100});
  }
  if (ok) ok = expect_reply("drive_release", client_->request(protocol::Drive{0.0, 0.0}));
  client_->set_heartbeat(Milliseconds{0});
  if (!ok) return false;
  if (!wait_at_rest("jog", 30.0)) return false;
  if (!refresh_pose(false)) return false;
  add_state_row("jog",
                "true distance to the door " + fixed(world_.true_distance_m(pose_), 3) + " m");
  return true;
}

bool Rehearsal::approach(double standoff_m, const std::string& step) {
  const Response r = client_->request(protocol::Approach{standoff_m});
  if (!expect_reply(step, r)) return false;
  const auto& body = std::get<protocol::ApproachAck>(r.get<protocol::Ack>()->body);
  if (!wait_at_rest(step, 60.0)) return false;
  if (!refresh_pose(false)) return false;
  add_row(
      step, r, standoff_m, world_.true_distance_m(pose_),
      "value: true distance to the door (m) after travelling " + fixed(body.travel_m, 3) + " m");
  return true;
}

std::optional<protocol::PlaneAck> Rehearsal::measure_plane(const std::string& step) {
  if (!refresh_pose(false)) return std::nullopt;
  protocol::MeasureDoorPlane m;
  const auto points = world_.plane_points(scenario_.plane_points);
  m.count = static_cast<std::uint8_t>(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    m.points[i] = camera(points[i]);
  const Response r = client_->request(m);
  if (!expect_reply(step, r)) return std::nullopt;
  const auto plane = std::get<protocol::PlaneAck>(r.get<protocol::Ack>()->body);
  add_row(step, r, world_.true_yaw_error_rad(pose_.yaw_rad), plane.yaw_deviation_rad,
          "value: yaw deviation (rad)");
  return plane;
}

bool Rehearsal::align() {
  const Response r = client_->request(protocol::AlignBase{});
  if (!expect_reply("align", r)) return false;
  add_row("align", r, std::nan(""), std::nan(""), "");
  const auto state = wait_while(protocol::ProcedureState::kAligning, 60.0);
  if (!state) return false;
  if (*state != protocol::ProcedureState::kAligned) {
    fail("alignment ended in state " + std::string(protocol::to_string(*state)), false);
    return false;
  }
  add_state_row("aligned", "");
  return true;
}

RunResult rehearse(const Scenario& scenario, const Eigen::Matrix4d& camera_to_base,
                   const GlobalOptions& options, std::vector<TraceRow>& trace,
                   bool& connection_failed) {
  Rehearsal rehearsal(scenario, camera_to_base, options, trace);
  RunResult result = rehearsal.run();
  rehearsal.take_trace();
  connection_failed = rehearsal.connection_failed();
  return result;
}

double wrap(double angle_rad) {
  return std::remainder(angle_rad, 2 * std::numbers::pi);
}

}  // namespace ajar::client::simulation
