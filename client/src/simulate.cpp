#include "ajar/client/simulate.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <mutex>
#include <numbers>
#include <ostream>
#include <set>
#include <stdexcept>
#include <thread>

#include <yaml-cpp/yaml.h>

#include "ajar/client/cli.hpp"
#include "ajar/client/client.hpp"
#include "ajar/client/output.hpp"
#include "ajar/core/geometry.hpp"
#include "ajar/daemon/config.hpp"

namespace ajar::client {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kDegToRad = std::numbers::pi / 180.0;

// ---- Scenario loading --------------------------------------------------------------------------

struct YamlReader {
  std::string path;

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw std::runtime_error(path + ": " + key + ": " + problem);
  }
  void check_keys(const YAML::Node& node, const std::string& where,
                  const std::set<std::string>& allowed) const {
    if (!node) return;
    if (!node.IsMap()) fail(where.empty() ? "(top level)" : where, "must be a mapping");
    for (const auto& kv : node) {
      const auto key = kv.first.as<std::string>();
      if (!allowed.contains(key)) {
        std::string list;
        for (const auto& a : allowed)
          list += (list.empty() ? "" : ", ") + a;
        fail(where.empty() ? key : where + "." + key, "unknown key (allowed: " + list + ")");
      }
    }
  }
  void number(const YAML::Node& node, const std::string& key, double& out, double lo,
              double hi) const {
    if (!node) return;
    try {
      out = node.as<double>();
    } catch (const YAML::Exception&) {
      fail(key, "not a number");
    }
    if (!std::isfinite(out) || out < lo || out > hi) {
      fail(key, "out of range (got " + std::to_string(out) + "; allowed " + std::to_string(lo) +
                    " .. " + std::to_string(hi) + ")");
    }
  }
  void integer(const YAML::Node& node, const std::string& key, int& out, int lo, int hi) const {
    double v = out;
    number(node, key, v, lo, hi);
    if (v != std::floor(v)) fail(key, "not an integer");
    out = static_cast<int>(v);
  }
};

// ---- Statistics helpers ------------------------------------------------------------------------

double rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v)
    s += x * x;
  return v.empty() ? 0 : std::sqrt(s / static_cast<double>(v.size()));
}
double mean_abs(const std::vector<double>& v) {
  double s = 0;
  for (double x : v)
    s += std::abs(x);
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}
double max_abs(const std::vector<double>& v) {
  double s = 0;
  for (double x : v)
    s = std::max(s, std::abs(x));
  return s;
}

// An angle difference in (-pi, pi] (odometry may wrap).
double wrap(double angle_rad) {
  return std::remainder(angle_rad, 2 * std::numbers::pi);
}

}  // namespace

Scenario load_scenario(const std::string& path) {
  YamlReader r{path};
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": cannot read the scenario: " + e.what());
  }
  Scenario s;
  r.check_keys(root, "",
               {"name", "description", "door", "sensor", "operator", "run", "tolerances", "expect",
                "drive"});
  s.name = root["name"] ? root["name"].as<std::string>() : path;
  if (root["description"]) s.description = root["description"].as<std::string>();
  const auto door = root["door"];
  if (!door) r.fail("door", "missing");
  r.check_keys(door, "door",
               {"hinge", "width_m", "height_m", "bottom_z_m", "distance_m", "yaw_deg", "yaw_rad",
                "lateral_offset_m", "handle"});
  if (door["hinge"]) {
    const auto hinge = door["hinge"].as<std::string>();
    if (hinge == "left") {
      s.hinge = Scenario::Hinge::kLeft;
    } else if (hinge == "right") {
      s.hinge = Scenario::Hinge::kRight;
    } else {
      r.fail("door.hinge", "must be left or right (got '" + hinge + "')");
    }
  }
  r.number(door["width_m"], "door.width_m", s.door_width_m, 0.1, 5);
  r.number(door["height_m"], "door.height_m", s.door_height_m, 0.5, 5);
  r.number(door["bottom_z_m"], "door.bottom_z_m", s.door_bottom_z_m, -3, 3);
  r.number(door["distance_m"], "door.distance_m", s.distance_m, 0.2, 10);
  if (door["yaw_deg"]) {
    double deg = 0;
    r.number(door["yaw_deg"], "door.yaw_deg", deg, -80, 80);
    s.yaw_rad = deg * kDegToRad;
  }
  r.number(door["yaw_rad"], "door.yaw_rad", s.yaw_rad, -1.4, 1.4);
  r.number(door["lateral_offset_m"], "door.lateral_offset_m", s.lateral_offset_m, -5, 5);
  if (const auto handle = door["handle"]) {
    r.check_keys(handle, "door.handle", {"axis_from_edge_m", "length_m", "height_m", "offset_m"});
    r.number(handle["axis_from_edge_m"], "door.handle.axis_from_edge_m", s.handle_axis_from_edge_m,
             0, 1);
    r.number(handle["length_m"], "door.handle.length_m", s.handle_length_m, 0.01, 1);
    r.number(handle["height_m"], "door.handle.height_m", s.handle_height_m, -3, 3);
    r.number(handle["offset_m"], "door.handle.offset_m", s.handle_offset_m, 0, 0.5);
  }
  if (const auto sensor = root["sensor"]) {
    r.check_keys(sensor, "sensor",
                 {"depth_noise_at_1m_m", "pixel_noise_px", "focal_length_px", "edge_inset_m"});
    r.number(sensor["depth_noise_at_1m_m"], "sensor.depth_noise_at_1m_m", s.depth_noise_at_1m_m, 0,
             0.1);
    r.number(sensor["pixel_noise_px"], "sensor.pixel_noise_px", s.pixel_noise_px, 0, 50);
    r.number(sensor["focal_length_px"], "sensor.focal_length_px", s.focal_length_px, 50, 5000);
    r.number(sensor["edge_inset_m"], "sensor.edge_inset_m", s.edge_inset_m, 0, 0.2);
  }
  if (const auto op = root["operator"]) {
    r.check_keys(op, "operator", {"width_pick_height_m", "plane_points"});
    r.number(op["width_pick_height_m"], "operator.width_pick_height_m", s.width_pick_height_m, -3,
             3);
    r.integer(op["plane_points"], "operator.plane_points", s.plane_points, 3, 16);
  }
  if (const auto run = root["run"]) {
    r.check_keys(run, "run", {"seed", "max_align_iterations"});
    double seed = static_cast<double>(s.seed);
    r.number(run["seed"], "run.seed", seed, 0, 4294967295.0);
    s.seed = static_cast<std::uint64_t>(seed);
    r.integer(run["max_align_iterations"], "run.max_align_iterations", s.max_align_iterations, 1,
              10);
  }
  if (const auto tol = root["tolerances"]) {
    r.check_keys(tol, "tolerances",
                 {"width_m", "handle_length_m", "residual_yaw_rad", "contact_m", "standoff_m"});
    r.number(tol["standoff_m"], "tolerances.standoff_m", s.standoff_tolerance_m, 0, 1);
    r.number(tol["width_m"], "tolerances.width_m", s.width_tolerance_m, 0, 1);
    r.number(tol["handle_length_m"], "tolerances.handle_length_m", s.handle_tolerance_m, 0, 1);
    r.number(tol["residual_yaw_rad"], "tolerances.residual_yaw_rad", s.residual_yaw_tolerance_rad,
             0, 1);
    r.number(tol["contact_m"], "tolerances.contact_m", s.contact_tolerance_m, 0, 1);
  }
  if (const auto drive = root["drive"]) {
    s.drive = true;
    r.check_keys(drive, "drive",
                 {"jog_m", "jog_speed_m_s", "width_standoff_m", "handle_standoff_m", "wheel_slip",
                  "encoder_noise_rad"});
    r.number(drive["jog_m"], "drive.jog_m", s.jog_m, 0, 5);
    r.number(drive["jog_speed_m_s"], "drive.jog_speed_m_s", s.jog_speed_m_s, 0.01, 1);
    r.number(drive["width_standoff_m"], "drive.width_standoff_m", s.width_standoff_m, 0.2, 5);
    r.number(drive["handle_standoff_m"], "drive.handle_standoff_m", s.handle_standoff_m, 0.2, 5);
    r.number(drive["wheel_slip"], "drive.wheel_slip", s.wheel_slip, 0, 0.5);
    r.number(drive["encoder_noise_rad"], "drive.encoder_noise_rad", s.encoder_noise_rad, 0, 0.1);
  }
  if (const auto expect = root["expect"]) {
    r.check_keys(expect, "expect", {"engaged"});
    if (expect["engaged"]) s.expect_engaged = expect["engaged"].as<bool>();
  }
  return s;
}

// ---- The world ---------------------------------------------------------------------------------

SimWorld::SimWorld(const Scenario& scenario, const Eigen::Matrix4d& camera_to_base_m)
    : scenario_(scenario), rng_(scenario.seed) {
  camera_to_base_.matrix() = camera_to_base_m;
}

core::Vec3 SimWorld::door_normal() const {
  return -core::Vec3(std::cos(scenario_.yaw_rad), std::sin(scenario_.yaw_rad), 0);
}

core::Vec3 SimWorld::door_point(double lateral_m, double z_m, double proud_m) const {
  const double c = std::cos(scenario_.yaw_rad);
  const double s = std::sin(scenario_.yaw_rad);
  const core::Vec3 foot(scenario_.distance_m * c, scenario_.distance_m * s, 0);
  const core::Vec3 lateral(-s, c, 0);
  return foot + lateral_m * lateral + core::Vec3(0, 0, z_m) + proud_m * door_normal();
}

namespace {
double hinge_sign(const Scenario& s) {
  return s.hinge == Scenario::Hinge::kLeft ? 1.0 : -1.0;
}
}  // namespace

core::Vec3 SimWorld::hinge_edge_point() const {
  const double h = hinge_sign(scenario_);
  const double lat =
      scenario_.lateral_offset_m + h * (scenario_.door_width_m / 2 - scenario_.edge_inset_m);
  return door_point(lat, scenario_.width_pick_height_m);
}

core::Vec3 SimWorld::moving_edge_point() const {
  const double h = hinge_sign(scenario_);
  const double lat =
      scenario_.lateral_offset_m - h * (scenario_.door_width_m / 2 - scenario_.edge_inset_m);
  return door_point(lat, scenario_.width_pick_height_m);
}

core::Vec3 SimWorld::handle_axis_point() const {
  const double h = hinge_sign(scenario_);
  const double lat = scenario_.lateral_offset_m - h * scenario_.door_width_m / 2 +
                     h * scenario_.handle_axis_from_edge_m;
  return door_point(lat, scenario_.handle_height_m, scenario_.handle_offset_m);
}

core::Vec3 SimWorld::handle_free_end_point() const {
  const double h = hinge_sign(scenario_);
  const double lat = scenario_.lateral_offset_m - h * scenario_.door_width_m / 2 +
                     h * (scenario_.handle_axis_from_edge_m + scenario_.handle_length_m);
  return door_point(lat, scenario_.handle_height_m, scenario_.handle_offset_m);
}

core::Vec3 SimWorld::contact_point() const {
  return handle_axis_point() + (handle_free_end_point() - handle_axis_point()) * (2.0 / 3.0);
}

std::vector<core::Vec3> SimWorld::plane_points(int count) {
  std::uniform_real_distribution<double> jitter(-0.03, 0.03);
  const double w = scenario_.door_width_m;
  const double c = scenario_.lateral_offset_m;
  const double z_lo = scenario_.door_bottom_z_m + 0.25 * scenario_.door_height_m;
  const double z_hi = scenario_.door_bottom_z_m + 0.75 * scenario_.door_height_m;
  std::vector<core::Vec3> points;
  if (count == 3) {
    // The paper's operator: a wide triangle on the leaf.
    points.push_back(door_point(c - 0.35 * w + jitter(rng_), z_lo + jitter(rng_)));
    points.push_back(door_point(c + 0.35 * w + jitter(rng_), z_lo + jitter(rng_)));
    points.push_back(door_point(c + jitter(rng_), z_hi + jitter(rng_)));
    return points;
  }
  for (int i = 0; i < count; ++i) {
    // A low-discrepancy spread over the leaf (lateral by the golden ratio, height evenly).
    const double u = std::fmod(0.1 + 0.6180339887 * i, 1.0) - 0.5;
    const double v = (i + 0.5) / count;
    points.push_back(
        door_point(c + 0.8 * w * u + jitter(rng_), z_lo + (z_hi - z_lo) * v + jitter(rng_)));
  }
  return points;
}

core::Vec3 SimWorld::to_camera(const core::Vec3& world_point, double base_yaw_rad) const {
  return to_camera(world_point, core::PlanarPose{0, 0, base_yaw_rad});
}

core::Vec3 SimWorld::to_camera(const core::Vec3& world_point, const core::PlanarPose& base) const {
  return camera_to_base_.inverse() * core::rebase(world_point, core::PlanarPose{}, base);
}

double SimWorld::true_distance_m(const core::PlanarPose& base) const {
  return door_normal().dot(core::Vec3(base.x_m, base.y_m, 0) - door_point(0, 0));
}

core::Vec3 SimWorld::pick(const core::Vec3& world_point, double base_yaw_rad) {
  return pick(world_point, core::PlanarPose{0, 0, base_yaw_rad});
}

core::Vec3 SimWorld::pick(const core::Vec3& world_point, const core::PlanarPose& base) {
  const double base_yaw_rad = base.yaw_rad;
  const core::Vec3 p = to_camera(world_point, base);
  if (p.z() <= 1e-3) return p;  // behind the camera: nothing sensible to add
  std::normal_distribution<double> unit(0.0, 1.0);
  const double f = scenario_.focal_length_px;
  // Pixel-picking error: a neighbouring pixel's ray, re-intersected with the picked surface (the
  // plane through the true point, parallel to the door).
  const double u = f * p.x() / p.z() + scenario_.pixel_noise_px * unit(rng_);
  const double v = f * p.y() / p.z() + scenario_.pixel_noise_px * unit(rng_);
  const core::Vec3 ray(u / f, v / f, 1.0);
  const core::Vec3 n_base = Eigen::AngleAxisd(-base_yaw_rad, core::Vec3::UnitZ()) * door_normal();
  const core::Vec3 n_cam = camera_to_base_.linear().transpose() * n_base;
  core::Vec3 picked = p;
  const double denom = n_cam.dot(ray);
  if (std::abs(denom) > 1e-6) {
    const double lambda = n_cam.dot(p) / denom;
    if (lambda > 0) picked = lambda * ray;
  }
  // Depth noise: sigma grows with the square of the depth (structured light).
  const double z = picked.z();
  const double sigma = scenario_.depth_noise_at_1m_m * z * z;
  const double z_noisy = z + sigma * unit(rng_);
  return picked * (z_noisy / z);
}

// ---- The closed loop ---------------------------------------------------------------------------

namespace {

struct TraceRow {
  std::uint64_t seed = 0;
  double t_s = 0;
  std::string step;
  std::string state;
  double base_yaw_rad = 0;        // in the world (odometry - start)
  double true_yaw_error_rad = 0;  // what is left to turn
  double true_value = std::nan("");
  double measured_value = std::nan("");
  double left_wheel_rad = std::nan("");
  double right_wheel_rad = std::nan("");
  std::string note;
};

struct RunResult {
  std::uint64_t seed = 0;
  bool completed = false;           // every step answered as expected
  std::string failure;              // first reason the run failed
  std::vector<std::string> missed;  // tolerances missed
  double true_width_m = 0, measured_width_m = 0;
  std::string direction, expected_direction;
  double true_handle_m = 0, measured_handle_m = 0;
  double yaw_before_true_rad = 0, yaw_before_measured_rad = 0;
  double yaw_after_true_rad = 0, yaw_after_measured_rad = 0;
  int align_iterations = 0;
  double plane_rms_m = 0;
  double cmd_left_rad = 0, cmd_right_rad = 0;
  std::int64_t cmd_left_counts = 0, cmd_right_counts = 0;
  double enc_left_rad = 0, enc_right_rad = 0;
  double contact_error_m = 0, reach_margin_m = 0;
  double final_standoff_m = std::nan("");  // true, after the procedure (driving scenarios)
  std::string final_state;
  bool ok() const { return completed && missed.empty(); }
};

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
    if (const auto why = client.connect(options_.endpoint); !why.empty()) {
      return fail("connect: " + why, true);
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

std::string csv_number(double v) {
  return std::isfinite(v) ? json_number(v) : "";
}

std::string csv_text(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c == '\n' ? ' ' : c;
  }
  return out + "\"";
}

void write_trace(const std::string& path, const std::vector<TraceRow>& rows) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write the trace file '" + path + "'");
  f << "seed,t_s,step,state,base_yaw_rad,true_yaw_error_rad,true_value,measured_value,"
       "left_wheel_rad,right_wheel_rad,note\n";
  for (const auto& r : rows) {
    f << r.seed << ',' << csv_number(r.t_s) << ',' << csv_text(r.step) << ',' << csv_text(r.state)
      << ',' << csv_number(r.base_yaw_rad) << ',' << csv_number(r.true_yaw_error_rad) << ','
      << csv_number(r.true_value) << ',' << csv_number(r.measured_value) << ','
      << csv_number(r.left_wheel_rad) << ',' << csv_number(r.right_wheel_rad) << ','
      << csv_text(r.note) << '\n';
  }
}

JsonObject report_json(const Scenario& s, const RunResult& r) {
  JsonObject o;
  o.add("type", "simulate_report").add("command", "simulate").add("ok", r.ok());
  o.add("scenario", s.name).add("seed", r.seed);
  o.add("true_width_m", r.true_width_m).add("width_m", r.measured_width_m);
  o.add("direction", r.direction).add("expected_direction", r.expected_direction);
  o.add("true_handle_length_m", r.true_handle_m).add("handle_length_m", r.measured_handle_m);
  o.add("true_yaw_before_rad", r.yaw_before_true_rad)
      .add("yaw_deviation_rad", r.yaw_before_measured_rad);
  o.add("plane_points", s.plane_points).add("rms_residual_m", r.plane_rms_m);
  JsonObject wa;
  wa.add("left", r.cmd_left_rad).add("right", r.cmd_right_rad);
  o.add("wheel_angle_rad", wa);
  JsonObject wc;
  wc.add("left", r.cmd_left_counts).add("right", r.cmd_right_counts);
  o.add("wheel_counts", wc);
  JsonObject we;
  we.add("left", r.enc_left_rad).add("right", r.enc_right_rad);
  o.add("encoder_wheel_angle_rad", we);
  o.add("align_iterations", r.align_iterations);
  o.add("true_yaw_after_rad", r.yaw_after_true_rad)
      .add("yaw_after_measured_rad", r.yaw_after_measured_rad);
  o.add("contact_error_m", r.contact_error_m).add("reach_margin_m", r.reach_margin_m);
  if (s.drive) {
    o.add("standoff_target_m", s.handle_standoff_m).add("true_standoff_m", r.final_standoff_m);
  }
  o.add("final_state", r.final_state);
  std::string missed = "[";
  for (std::size_t i = 0; i < r.missed.size(); ++i) {
    if (i) missed += ", ";
    missed += json_string(r.missed[i]);
  }
  missed += "]";
  o.add_raw("missed", missed);
  if (!r.failure.empty()) o.add("error", error_object("SIMULATION_FAILED", "", r.failure));
  return o;
}

std::string report_text(const Scenario& s, const RunResult& r) {
  std::string t = "scenario " + s.name + " (seed " + std::to_string(r.seed) + ", " +
                  std::to_string(s.plane_points) + " plane points): " + (r.ok() ? "PASS" : "FAIL") +
                  "\n";
  if (!r.failure.empty()) t += "  failed: " + r.failure + "\n";
  t += "  door width     true " + fixed(r.true_width_m, 4) + " m, measured " +
       fixed(r.measured_width_m, 4) + " m (error " +
       fixed(r.measured_width_m - r.true_width_m, 4, true) + ", tolerance " +
       fixed(s.width_tolerance_m, 4) + "), direction " + r.direction + " (expected " +
       r.expected_direction + ")\n";
  t += "  handle length  true " + fixed(r.true_handle_m, 4) + " m, measured " +
       fixed(r.measured_handle_m, 4) + " m (error " +
       fixed(r.measured_handle_m - r.true_handle_m, 4, true) + ")\n";
  t += "  yaw before     true " + fixed(r.yaw_before_true_rad, 5, true) + " rad, measured " +
       fixed(r.yaw_before_measured_rad, 5, true) + " rad (plane rms " + fixed(r.plane_rms_m, 4) +
       " m)\n";
  t += "  wheel angles   commanded L " + fixed(r.cmd_left_rad, 5, true) + " R " +
       fixed(r.cmd_right_rad, 5, true) + " rad (" + std::to_string(r.cmd_left_counts) + " / " +
       std::to_string(r.cmd_right_counts) + " counts), encoders over the alignment(s) L " +
       fixed(r.enc_left_rad, 5, true) + " R " + fixed(r.enc_right_rad, 5, true) + " rad\n";
  t += "  yaw after      true " + fixed(r.yaw_after_true_rad, 5, true) + " rad (tolerance " +
       fixed(s.residual_yaw_tolerance_rad, 4) + "), measured " +
       fixed(r.yaw_after_measured_rad, 5, true) + " rad, " + std::to_string(r.align_iterations) +
       " alignment(s)\n";
  t += "  contact        error " + fixed(r.contact_error_m, 4) + " m, reach margin " +
       fixed(r.reach_margin_m, 4) + " m\n";
  if (s.drive) {
    t += "  standoff       true " + fixed(r.final_standoff_m, 4) + " m, target " +
         fixed(s.handle_standoff_m, 4) + " m (error " +
         fixed(r.final_standoff_m - s.handle_standoff_m, 4, true) + ", tolerance " +
         fixed(s.standoff_tolerance_m, 4) + "); started " + fixed(s.distance_m, 3) +
         " m away, jogged " + fixed(s.jog_m, 3) + " m\n";
  }
  t += "  final state    " + (r.final_state.empty() ? std::string("-") : r.final_state);
  for (const auto& m : r.missed)
    t += "\n  MISSED: " + m;
  return t;
}

}  // namespace

int run_simulate(const Command& command, const GlobalOptions& options, std::ostream& out,
                 std::ostream& err) {
  std::string scenario_path, trace_path, config_path;
  int seeds = 1;
  int plane_points = 0;  // 0: the scenario's
  std::optional<std::uint64_t> seed;
  for (std::size_t i = 0; i < command.args.size(); ++i) {
    const std::string& a = command.args[i];
    auto value = [&]() -> const std::string* {
      return i + 1 < command.args.size() ? &command.args[++i] : nullptr;
    };
    if (a == "--trace" || a == "--config" || a == "--seeds" || a == "--seed" ||
        a == "--plane-points") {
      const std::string* v = value();
      if (!v) {
        err << "ajarctl: simulate: " << a << " needs a value\n";
        return kExitUsage;
      }
      if (a == "--trace") {
        trace_path = *v;
      } else if (a == "--config") {
        config_path = *v;
      } else {
        unsigned long long n = 0;
        const auto [p, ec] = std::from_chars(v->data(), v->data() + v->size(), n);
        if (ec != std::errc{} || p != v->data() + v->size() ||
            (a == "--seeds" && (n < 1 || n > 100000))) {
          err << "ajarctl: simulate: " << a << " wants a whole number, got '" << *v << "'\n";
          return kExitUsage;
        }
        if (a == "--plane-points" && (n < 3 || n > 16)) {
          err << "ajarctl: simulate: --plane-points wants 3..16, got '" << *v << "'\n";
          return kExitUsage;
        }
        if (a == "--plane-points") {
          plane_points = static_cast<int>(n);
        } else if (a == "--seeds") {
          seeds = static_cast<int>(n);
        } else {
          seed = n;
        }
      }
    } else if (!a.empty() && a[0] != '-' && scenario_path.empty()) {
      scenario_path = a;
    } else {
      err << "ajarctl: simulate: unexpected argument '" << a << "'\n";
      return kExitUsage;
    }
  }
  if (scenario_path.empty()) {
    err << "ajarctl: simulate wants SCENARIO.yaml\n";
    return kExitUsage;
  }
  Scenario scenario;
  Eigen::Matrix4d camera_to_base;
  try {
    scenario = load_scenario(scenario_path);
    camera_to_base = config_path.empty() ? core::paper_camera_to_base_m()
                                         : daemon::load_config(config_path).camera_to_base_m;
  } catch (const std::exception& e) {
    err << "ajarctl: simulate: " << e.what() << '\n';
    return kExitUsage;
  }
  if (seed) scenario.seed = *seed;
  if (plane_points != 0) scenario.plane_points = plane_points;

  std::vector<TraceRow> trace;
  std::vector<double> yaw_before_error, yaw_after;
  int passed = 0;
  bool connection_failed = false;
  for (int i = 0; i < seeds; ++i) {
    Scenario run_scenario = scenario;
    run_scenario.seed = scenario.seed + static_cast<std::uint64_t>(i);
    Rehearsal rehearsal(run_scenario, camera_to_base, options, trace);
    const RunResult result = rehearsal.run();
    rehearsal.take_trace();
    if (result.ok()) ++passed;
    // Every run that got as far as an alignment counts in the statistics (also one that the
    // daemon never accepted as aligned).
    if (result.align_iterations > 0) {
      yaw_before_error.push_back(result.yaw_before_measured_rad - result.yaw_before_true_rad);
      yaw_after.push_back(result.yaw_after_true_rad);
    }
    if (options.json) {
      out << report_json(run_scenario, result).str() << '\n';
    } else if (seeds == 1) {
      out << report_text(run_scenario, result) << '\n';
    } else {
      out << "seed " << run_scenario.seed << ": " << (result.ok() ? "PASS" : "FAIL")
          << " yaw measured-true "
          << fixed(result.yaw_before_measured_rad - result.yaw_before_true_rad, 5, true)
          << " rad, residual yaw after alignment " << fixed(result.yaw_after_true_rad, 5, true)
          << " rad" << (result.failure.empty() ? "" : " (" + result.failure + ")") << '\n';
    }
    out.flush();
    if (rehearsal.connection_failed()) {
      connection_failed = true;
      break;
    }
  }
  if (seeds > 1) {
    JsonObject o;
    o.add("type", "simulate_summary").add("command", "simulate").add("ok", passed == seeds);
    o.add("scenario", scenario.name).add("plane_points", scenario.plane_points);
    o.add("runs", seeds).add("passed", passed);
    o.add("yaw_error_before_rms_rad", rms(yaw_before_error))
        .add("yaw_error_before_max_abs_rad", max_abs(yaw_before_error));
    o.add("residual_yaw_rms_rad", rms(yaw_after))
        .add("residual_yaw_mean_abs_rad", mean_abs(yaw_after))
        .add("residual_yaw_max_abs_rad", max_abs(yaw_after));
    if (options.json) {
      out << o.str() << '\n';
    } else {
      out << scenario.name << ": " << passed << "/" << seeds << " runs passed, "
          << scenario.plane_points << " plane points\n"
          << "  first plane yaw error (measured - true): rms " << fixed(rms(yaw_before_error), 5)
          << " rad, max |.| " << fixed(max_abs(yaw_before_error), 5) << " rad\n"
          << "  residual yaw after alignment (true):     rms " << fixed(rms(yaw_after), 5)
          << " rad, mean |.| " << fixed(mean_abs(yaw_after), 5) << " rad, max |.| "
          << fixed(max_abs(yaw_after), 5) << " rad\n";
    }
  }
  if (!trace_path.empty()) {
    try {
      write_trace(trace_path, trace);
    } catch (const std::exception& e) {
      err << "ajarctl: simulate: " << e.what() << '\n';
      return kExitUsage;
    }
  }
  if (connection_failed) return kExitConnection;
  return passed == seeds ? kExitOk : kExitRefused;
}

}  // namespace ajar::client
