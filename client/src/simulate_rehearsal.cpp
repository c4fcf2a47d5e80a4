#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <numbers>
#include <optional>
#include <random>
#include <thread>

#include "ajar/client/cli.hpp"
#include "ajar/client/client.hpp"
#include "ajar/client/output.hpp"
#include "ajar/core/geometry.hpp"
#include "simulate_detail.hpp"

namespace ajar::client::simulation {
namespace {

using Clock = std::chrono::steady_clock;

class Rehearsal {
 public:
  Rehearsal(const Scenario& scenario, const Eigen::Matrix4d& camera_to_base,
            const GlobalOptions& options, std::vector<TraceRow>& trace)
      : scenario_(scenario), world_(scenario, camera_to_base), options_(options), trace_(trace) {}

  RunResult run() {
    result_.seed = scenario_.seed;
    result_.expected_direction = world_.expected_ccw() ? "CCW" : "CW";
    result_.true_width_m = scenario_.door_width_m - 2 * scenario_.edge_inset_m;
    result_.true_handle_m = scenario_.handle_length_m;
    ClientOptions co;
    co.request_timeout = Milliseconds{static_cast<std::int64_t>(options_.timeout_s * 1000)};
    co.retries = options_.retries;
    co.tls = options_.tls;
    co.client_name = "ajarctl simulate";
    Client client(co);
    client_ = &client;
    client.on_telemetry([this](const protocol::Telemetry& t) {
      std::lock_guard lock(telemetry_mutex_);
      last_telemetry_ = t;
      has_telemetry_ = true;
      const core::PlanarPose truth = integrate_truth(t);
      if (recording_) {
        // Not row_now(): base_yaw_ belongs to the main thread.
        TraceRow row;
        row.seed = scenario_.seed;
        row.t_s = std::chrono::duration<double>(Clock::now() - start_).count();
        row.step = "telemetry";
        row.state = std::string(protocol::to_string(t.state));
        row.base_yaw_rad = wrap(truth.yaw_rad);
        row.true_yaw_error_rad = world_.true_yaw_error_rad(row.base_yaw_rad);
        row.left_wheel_rad = t.left_wheel_rad;
        row.right_wheel_rad = t.right_wheel_rad;
        telemetry_rows_.push_back(row);
      }
    });
    if (const auto connected = client.connect(options_.endpoint); !connected) {
      return fail("connect: " + connected.error().message, true);
    }
    if (!expect_reply("hello", client.hello(protocol::Role::kController, options_.take_over))) {
      return result_;
    }
    {
      const Response model = client.request(protocol::GetRobotModel{});
      if (const auto* m = model.get<protocol::RobotModel>()) {
        geometry_.wheel_radius_m = m->wheel_radius_m;
        geometry_.turning_radius_m = m->turning_radius_m;
      } else if (noisy()) {
        return fail("get_robot_model: " + response_text("get_robot_model", model), false);
      }
    }
    start_ = Clock::now();
    protocol::Reset reset;
    reset.clear_parameters = true;
    if (!expect_reply("reset", client.request(reset))) return result_;
    if (!refresh_pose(true)) return result_;
    (void)client.request(protocol::Subscribe{50.0f});
    recording_ = true;

    // 0. Fig. 4 from afar: jog toward the door, measure the width, Approach to the width standoff.
    if (scenario_.drive) {
      if (scenario_.jog_m > 0 && !jog(scenario_.jog_m, scenario_.jog_speed_m_s)) return result_;
      if (!measure_width("measure_width_far")) return result_;
      if (!approach(scenario_.width_standoff_m, "approach_width")) return result_;
    }
    // 1. Door width.
    if (!measure_width("measure_width")) return result_;
    if (scenario_.drive && !approach(scenario_.handle_standoff_m, "approach_handle")) {
      return result_;
    }
    // 2. Handle.
    {
      if (!refresh_pose(false)) return result_;
      protocol::MeasureHandle m;
      m.p1_axis = camera(world_.handle_axis_point());
      m.p2_free_end = camera(world_.handle_free_end_point());
      const Response r = client.request(m);
      if (!expect_reply("measure_handle", r)) return result_;
      const auto& span = std::get<protocol::SpanAck>(r.get<protocol::Ack>()->body);
      result_.measured_handle_m = span.length_m;
      add_row("measure_handle", r, result_.true_handle_m, span.length_m,
              core::to_string(span.direction));
    }
    // 3. Plane.
    const auto first = measure_plane("measure_plane");
    if (!first) return result_;
    result_.yaw_before_true_rad = world_.true_yaw_error_rad(pose_.yaw_rad);
    result_.yaw_before_measured_rad = first->yaw_deviation_rad;
    result_.plane_rms_m = first->rms_residual_m;
    result_.cmd_left_rad = first->left_wheel_rad;
    result_.cmd_right_rad = first->right_wheel_rad;
    result_.cmd_left_counts = first->left_counts;
    result_.cmd_right_counts = first->right_counts;

    // 4. Align, re-measure, until the daemon keeps the alignment. Encoder angles are reported as
    // the change over the alignment(s) (the encoders count since the daemon started).
    const auto encoders_before = fresh_telemetry();
    bool aligned = false;
    for (int i = 0; i < scenario_.max_align_iterations && !aligned; ++i) {
      ++result_.align_iterations;
      if (!align()) return result_;
      const auto again = measure_plane("remeasure_plane");
      if (!again) return result_;
      result_.yaw_after_true_rad = world_.true_yaw_error_rad(pose_.yaw_rad);
      result_.yaw_after_measured_rad = again->yaw_deviation_rad;
      aligned = last_state_ == protocol::ProcedureState::kAligned;
    }
    if (!aligned) {
      return fail("still not aligned after " + std::to_string(scenario_.max_align_iterations) +
                      " alignment(s)",
                  false);
    }
    if (const auto encoders_after = fresh_telemetry(); encoders_before && encoders_after) {
      result_.enc_left_rad = encoders_after->left_wheel_rad - encoders_before->left_wheel_rad;
      result_.enc_right_rad = encoders_after->right_wheel_rad - encoders_before->right_wheel_rad;
    }
    // 5. Contact point, from the aligned pose.
    {
      if (!refresh_pose(false)) return result_;
      const core::Vec3 truth_world = world_.contact_point();
      protocol::SetContactPoint m;
      m.contact = camera(truth_world);
      const Response r = client.request(m);
      if (!expect_reply("contact", r)) return result_;
      const auto& contact = std::get<protocol::ContactAck>(r.get<protocol::Ack>()->body);
      const core::Vec3 truth_base = core::rebase(truth_world, core::PlanarPose{}, pose_);
      result_.contact_error_m = (contact.contact_base_m - truth_base).norm();
      result_.reach_margin_m = contact.reach_margin_m;
      add_row("contact", r, 0, result_.contact_error_m, "value: contact error (m)");
    }
    // 6. Engage.
    {
      const Response r = client.request(protocol::Engage{});
      if (!expect_reply("engage", r)) return result_;
      add_row("engage", r, std::nan(""), std::nan(""), "");
      const auto final_state = wait_while(protocol::ProcedureState::kEngaging, 60.0);
      if (!final_state) return result_;
      result_.final_state = std::string(protocol::to_string(*final_state));
      add_state_row("engaged", "");
      if (scenario_.expect_engaged && *final_state != protocol::ProcedureState::kEngaged) {
        return fail("engage ended in state " + result_.final_state, false);
      }
    }
    if (scenario_.drive) result_.final_standoff_m = world_.true_distance_m(pose_);
    recording_ = false;
    (void)client.request(protocol::Subscribe{});
    result_.completed = true;
    check_tolerances();
    return result_;
  }

  void take_trace() {
    std::lock_guard lock(telemetry_mutex_);
    for (auto& r : telemetry_rows_)
      trace_.push_back(r);
    telemetry_rows_.clear();
  }

  bool connection_failed() const { return connection_failed_; }

 private:
  // A telemetry sample taken after this call (waits up to 1 s for it).
  std::optional<protocol::Telemetry> fresh_telemetry() {
    std::uint64_t seen = 0;
    {
      std::lock_guard lock(telemetry_mutex_);
      seen = has_telemetry_ ? last_telemetry_.daemon_time_ns : 0;
    }
    const auto deadline = Clock::now() + Milliseconds{1000};
    while (Clock::now() < deadline) {
      {
        std::lock_guard lock(telemetry_mutex_);
        if (has_telemetry_ && last_telemetry_.daemon_time_ns > seen) return last_telemetry_;
      }
      std::this_thread::sleep_for(Milliseconds{5});
    }
    return std::nullopt;
  }

  RunResult fail(std::string why, bool connection) {
    if (result_.failure.empty()) result_.failure = std::move(why);
    connection_failed_ = connection_failed_ || connection;
    recording_ = false;
    return result_;
  }

  bool expect_reply(const std::string& step, const Response& r) {
    if (r.ok()) {
      if (const auto* ack = r.get<protocol::Ack>()) last_state_ = ack->state;
      return true;
    }
    add_row(step, r, std::nan(""), std::nan(""), response_text(step, r));
    fail(response_text(step, r), r.outcome != Outcome::kRefused);
    return false;
  }

  protocol::FramedPoint camera(const core::Vec3& world_point) {
    const core::Vec3 p = world_.pick(world_point, pose_);
    return framed(core::Frame::kCamera, p.x(), p.y(), p.z());
  }

  bool noisy() const { return scenario_.wheel_slip > 0 || scenario_.encoder_noise_rad > 0; }

  static core::PlanarPose odometry_of(const protocol::Status& s) {
    return {s.odometry_x_m, s.odometry_y_m, s.base_yaw_odometry_rad};
  }

  // The base pose in the world (the base frame at the start of the run) from an odometry pose.
  core::PlanarPose world_pose(const core::PlanarPose& odometry) const {
    const core::Vec3 p = core::rebase(core::Vec3::Zero(), odometry, odom0_);
    return {p.x(), p.y(), odometry.yaw_rad - odom0_.yaw_rad};
  }

  // Called with every telemetry sample (telemetry_mutex_ held): advances the true pose by the
  // encoder deltas with the scenario's slip and noise. Returns the truth.
  core::PlanarPose integrate_truth(const protocol::Telemetry& t) {
    if (!noisy()) return world_pose({t.odometry_x_m, t.odometry_y_m, t.base_yaw_odometry_rad});
    if (have_wheels_) {
      std::normal_distribution<double> noise(0.0, scenario_.encoder_noise_rad);
      const double keep = 1.0 - scenario_.wheel_slip;
      const double dl = (t.left_wheel_rad - wheels_[0]) * keep +
                        (scenario_.encoder_noise_rad > 0 ? noise(truth_rng_) : 0.0);
      const double dr = (t.right_wheel_rad - wheels_[1]) * keep +
                        (scenario_.encoder_noise_rad > 0 ? noise(truth_rng_) : 0.0);
      truth_ = core::integrate_odometry(truth_, dl, dr, geometry_);
    }
    have_wheels_ = true;
    wheels_[0] = t.left_wheel_rad;
    wheels_[1] = t.right_wheel_rad;
    return truth_;
  }

  bool refresh_pose(bool first) {
    const Response r = client_->request(protocol::GetStatus{});
    if (!expect_reply("status", r)) return false;
    const auto& s = *r.get<protocol::Status>();
    if (first) {
      std::lock_guard lock(telemetry_mutex_);
      odom0_ = odometry_of(s);
    }
    last_state_ = s.state;
    if (!noisy()) {
      std::lock_guard lock(telemetry_mutex_);
      pose_ = world_pose(odometry_of(s));
      return true;
    }
    if (!first && !fresh_telemetry()) return false;  // the truth is integrated from telemetry
    std::lock_guard lock(telemetry_mutex_);
    pose_ = truth_;
    return true;
  }

  bool measure_width(const std::string& step) {
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

  // Teleop: Drive straight at `speed` re-sent every 0.1 s (a held key) until the odometry says
  // `distance` was covered, then release (Drive 0) and wait for the base to rest.
  bool jog(double distance_m, double speed_m_s) {
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

  bool approach(double standoff_m, const std::string& step) {
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

  // Polls the status (which also feeds the deadman) until the wheels rest (Telemetry `moving`
  // false on two fresh samples), failing on a latched fault.
  bool wait_at_rest(const std::string& step, double timeout_s) {
    client_->set_heartbeat(Milliseconds{100});
    const auto deadline = Clock::now() + Milliseconds{static_cast<std::int64_t>(timeout_s * 1e3)};
    int resting = 0;
    bool ok = false;
    while (Clock::now() < deadline) {
      const Response st = client_->request(protocol::GetStatus{});
      if (!expect_reply("status", st)) break;
      if (st.get<protocol::Status>()->latched_fault != ErrorCode::kOk) {
        fail(step + ": fault latched: " +
                 std::string(ajar::to_string(st.get<protocol::Status>()->latched_fault)),
             false);
        break;
      }
      const auto t = fresh_telemetry();
      if (t && !t->moving) {
        if (++resting >= 2) {
          ok = true;
          break;
        }
      } else {
        resting = 0;
      }
    }
    client_->set_heartbeat(Milliseconds{0});
    if (!ok && result_.failure.empty()) fail(step + ": the base did not come to rest", false);
    return ok;
  }

  std::optional<protocol::PlaneAck> measure_plane(const std::string& step) {
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

  bool align() {
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

  // Polls the status (which also feeds the deadman) while the state is `busy`.
  std::optional<protocol::ProcedureState> wait_while(protocol::ProcedureState busy,
                                                     double timeout_s) {
    client_->set_heartbeat(Milliseconds{100});
    const auto deadline = Clock::now() + Milliseconds{static_cast<std::int64_t>(timeout_s * 1e3)};
    std::optional<protocol::ProcedureState> out;
    while (Clock::now() < deadline) {
      const Response r = client_->request(protocol::GetStatus{});
      if (!expect_reply("status", r)) break;
      const auto& s = *r.get<protocol::Status>();
      if (!noisy()) pose_ = world_pose(odometry_of(s));
      last_state_ = s.state;
      if (s.state != busy) {
        if (s.latched_fault != ErrorCode::kOk) {
          fail("fault latched: " + std::string(ajar::to_string(s.latched_fault)), false);
          break;
        }
        out = s.state;
        break;
      }
      std::this_thread::sleep_for(Milliseconds{20});
    }
    client_->set_heartbeat(Milliseconds{0});
    if (!out && result_.failure.empty()) {
      fail("still " + std::string(protocol::to_string(busy)) + " after " +
               std::to_string(timeout_s) + " s",
           false);
    }
    return out;
  }

  TraceRow row_now(const std::string& step, const std::string& state) const {
    TraceRow row;
    row.seed = scenario_.seed;
    row.t_s = std::chrono::duration<double>(Clock::now() - start_).count();
    row.step = step;
    row.state = state;
    row.base_yaw_rad = pose_.yaw_rad;
    row.true_yaw_error_rad = world_.true_yaw_error_rad(pose_.yaw_rad);
    return row;
  }

  void add_row(const std::string& step, const Response& r, double truth, double measured,
               const std::string& note) {
    std::string state;
    if (const auto* ack = r.get<protocol::Ack>()) state = protocol::to_string(ack->state);
    if (r.outcome == Outcome::kRefused) state = "refused";
    TraceRow row = row_now(step, state);
    row.true_value = truth;
    row.measured_value = measured;
    row.note = note;
    std::lock_guard lock(telemetry_mutex_);
    telemetry_rows_.push_back(row);
  }

  void add_state_row(const std::string& step, const std::string& note) {
    TraceRow row = row_now(step, std::string(protocol::to_string(last_state_)));
    row.note = note;
    std::lock_guard lock(telemetry_mutex_);
    telemetry_rows_.push_back(row);
  }

  void check_tolerances() {
    auto check = [&](const char* what, double error, double tol) {
      if (!(std::abs(error) <= tol)) {
        result_.missed.push_back(std::string(what) + " error " + fixed(error, 5, true) +
                                 " beyond " + fixed(tol, 5));
      }
    };
    check("width", result_.measured_width_m - result_.true_width_m, scenario_.width_tolerance_m);
    check("handle length", result_.measured_handle_m - result_.true_handle_m,
          scenario_.handle_tolerance_m);
    check("residual yaw", result_.yaw_after_true_rad, scenario_.residual_yaw_tolerance_rad);
    check("contact", result_.contact_error_m, scenario_.contact_tolerance_m);
    if (scenario_.drive) {
      check("final standoff", result_.final_standoff_m - scenario_.handle_standoff_m,
            scenario_.standoff_tolerance_m);
    }
    if (result_.direction != result_.expected_direction) {
      result_.missed.push_back("direction " + result_.direction + ", expected " +
                               result_.expected_direction);
    }
  }

  const Scenario& scenario_;
  SimWorld world_;
  const GlobalOptions& options_;
  std::vector<TraceRow>& trace_;
  Client* client_ = nullptr;
  RunResult result_;
  bool connection_failed_ = false;
  core::PlanarPose odom0_;       // the daemon's odometry when the run started
  core::PlanarPose pose_;        // the true base pose in the world, as of the last refresh_pose()
  core::BaseGeometry geometry_;  // R_W, R_B from the daemon's RobotModel
  // The truth integrated from telemetry (slip, noise); guarded by telemetry_mutex_.
  core::PlanarPose truth_;
  bool have_wheels_ = false;
  double wheels_[2] = {0, 0};
  std::mt19937_64 truth_rng_{scenario_.seed ^ 0x5eedULL};
  protocol::ProcedureState last_state_ = protocol::ProcedureState::kAwaitingWidth;
  Clock::time_point start_ = Clock::now();
  std::mutex telemetry_mutex_;
  protocol::Telemetry last_telemetry_;
  bool has_telemetry_ = false;
  std::atomic<bool> recording_{false};
  std::vector<TraceRow> telemetry_rows_;
};

}  // namespace

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
