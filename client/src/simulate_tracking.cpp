// Following the base during a rehearsal (simulate_rehearsal.hpp): the telemetry the daemon streams,
// the true pose (the daemon's odometry, or integrated from the wheels with the scenario's slip and
// encoder noise), and waiting for the wheels to rest or for a state to end while feeding the
// deadman.
#include <random>
#include <thread>

#include "simulate_rehearsal.hpp"

namespace ajar::client::simulation {

void Rehearsal::on_telemetry(const protocol::Telemetry& t) {
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
}

std::optional<protocol::Telemetry> Rehearsal::fresh_telemetry() {
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

core::PlanarPose Rehearsal::world_pose(const core::PlanarPose& odometry) const {
  const core::Vec3 p = core::rebase(core::Vec3::Zero(), odometry, odom0_);
  return {p.x(), p.y(), odometry.yaw_rad - odom0_.yaw_rad};
}

core::PlanarPose Rehearsal::integrate_truth(const protocol::Telemetry& t) {
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

bool Rehearsal::refresh_pose(bool first) {
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

bool Rehearsal::wait_at_rest(const std::string& step, double timeout_s) {
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

std::optional<protocol::ProcedureState> Rehearsal::wait_while(protocol::ProcedureState busy,
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
    fail("still " + std::string(protocol::to_string(busy)) + " after " + std::to_string(timeout_s) +
             " s",
         false);
  }
  return out;
}

}  // namespace ajar::client::simulation
