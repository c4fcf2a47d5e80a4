// One rehearsal of ajarctl simulate against a live ajard (private to ajar_ctl; rehearse() in
// simulate_detail.hpp is its entry): the simulated world answers every measurement the procedure
// asks for, the true base pose follows the daemon's wheels, and each step leaves a trace row.
//   simulate_rehearsal.cpp  the procedure's steps, in order (run)
//   simulate_tracking.cpp   telemetry, the true pose, waiting for rest or for a state to end
//   simulate_record.cpp     trace rows, the first failure, the tolerance check
// Threads: the client's reader thread calls on_telemetry; everything else runs on the caller's.
// telemetry_mutex_ guards what both touch (the truth, the last sample, the telemetry rows).
#pragma once

#include <atomic>
#include <chrono>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "ajar/client/client.hpp"
#include "ajar/core/geometry.hpp"
#include "simulate_detail.hpp"

namespace ajar::client::simulation {

class Rehearsal {
 public:
  Rehearsal(const Scenario& scenario, const Eigen::Matrix4d& camera_to_base,
            const GlobalOptions& options, std::vector<TraceRow>& trace)
      : scenario_(scenario), world_(scenario, camera_to_base), options_(options), trace_(trace) {}

  RunResult run();
  void take_trace();  // moves the recorded rows to the caller's trace
  bool connection_failed() const { return connection_failed_; }

 private:
  using Clock = std::chrono::steady_clock;

  // ---- simulate_rehearsal.cpp: the steps; false (or nullopt) when the run failed ----
  ClientOptions client_options() const;
  // Connect, Hello as the controller, the robot model, Reset, the world's origin, telemetry.
  bool start_session();
  bool approach_from_afar();  // jog, measure the width, Approach to the width standoff
  bool measure_handle();
  bool measure_first_plane();  // the yaw before alignment and the wheels' command
  bool align_until_kept();     // Align and measure again until the daemon keeps it
  bool set_contact_point();    // from the aligned pose
  bool engage();               // Engage and wait for its end
  bool measure_width(const std::string& step);
  // Teleop: Drive straight at `speed` re-sent every 0.1 s (a held key) until the odometry says
  // `distance` was covered, then release (Drive 0) and wait for the base to rest.
  bool jog(double distance_m, double speed_m_s);
  bool approach(double standoff_m, const std::string& step);
  std::optional<protocol::PlaneAck> measure_plane(const std::string& step);
  bool align();
  // A world point as the camera sees it from the current true pose (with the sensor's noise).
  protocol::FramedPoint camera(const core::Vec3& world_point) {
    const core::Vec3 p = world_.pick(world_point, pose_);
    return framed(core::Frame::kCamera, p.x(), p.y(), p.z());
  }

  // ---- simulate_tracking.cpp ----
  void on_telemetry(const protocol::Telemetry& t);  // the client's reader thread
  // A telemetry sample taken after this call (waits up to 1 s for it).
  std::optional<protocol::Telemetry> fresh_telemetry();
  bool noisy() const { return scenario_.wheel_slip > 0 || scenario_.encoder_noise_rad > 0; }
  static core::PlanarPose odometry_of(const protocol::Status& s) {
    return {s.odometry_x_m, s.odometry_y_m, s.base_yaw_odometry_rad};
  }
  // The base pose in the world (the base frame at the start of the run) from an odometry pose.
  core::PlanarPose world_pose(const core::PlanarPose& odometry) const;
  // Called with every telemetry sample (telemetry_mutex_ held): advances the true pose by the
  // encoder deltas with the scenario's slip and noise. Returns the truth.
  core::PlanarPose integrate_truth(const protocol::Telemetry& t);
  bool refresh_pose(bool first);  // pose_ from a fresh Status (first: it is the world's origin)
  // Polls the status (which also feeds the deadman) until the wheels rest (Telemetry `moving`
  // false on two fresh samples), failing on a latched fault.
  bool wait_at_rest(const std::string& step, double timeout_s);
  // Polls the status (which also feeds the deadman) while the state is `busy`.
  std::optional<protocol::ProcedureState> wait_while(protocol::ProcedureState busy,
                                                     double timeout_s);

  // ---- simulate_record.cpp ----
  RunResult fail(std::string why, bool connection);               // keeps the first reason
  bool expect_reply(const std::string& step, const Response& r);  // else a row and fail()
  TraceRow row_now(const std::string& step, const std::string& state) const;
  void add_row(const std::string& step, const Response& r, double truth, double measured,
               const std::string& note);
  void add_state_row(const std::string& step, const std::string& note);
  void check_tolerances();

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

}  // namespace ajar::client::simulation
