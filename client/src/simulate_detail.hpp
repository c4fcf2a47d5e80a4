// ajarctl simulate's pieces (private to ajar_ctl): the rehearsal against a live ajard, its result
// and trace rows, and the report writers. simulate.hpp is the public face (Scenario, SimWorld,
// run_simulate); simulate_scenario.cpp loads scenarios, simulate_world.cpp is the world and the
// sensor, simulate_rehearsal.hpp the rehearsal (the procedure, following the base, the record),
// simulate.cpp reports and runs seeds.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ajar/client/output.hpp"
#include "ajar/client/simulate.hpp"

namespace ajar::client::simulation {

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

// One closed-loop run of `scenario` against the daemon at options.endpoint. Appends its trace rows
// to `trace`; `connection_failed` says whether the daemon could not be reached or went away.
RunResult rehearse(const Scenario& scenario, const Eigen::Matrix4d& camera_to_base,
                   const GlobalOptions& options, std::vector<TraceRow>& trace,
                   bool& connection_failed);

// An angle difference in (-pi, pi] (odometry may wrap).
double wrap(double angle_rad);

}  // namespace ajar::client::simulation
