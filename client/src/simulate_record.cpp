// What a rehearsal records (simulate_rehearsal.hpp): its trace rows, its first failure, and the
// scenario's tolerances checked at the end.
#include <cmath>
#include <mutex>

#include "ajar/client/output.hpp"
#include "simulate_rehearsal.hpp"

namespace ajar::client::simulation {

void Rehearsal::take_trace() {
  std::lock_guard lock(telemetry_mutex_);
  for (auto& r : telemetry_rows_)
    trace_.push_back(r);
  telemetry_rows_.clear();
}

RunResult Rehearsal::fail(std::string why, bool connection) {
  if (result_.failure.empty()) result_.failure = std::move(why);
  connection_failed_ = connection_failed_ || connection;
  recording_ = false;
  return result_;
}

bool Rehearsal::expect_reply(const std::string& step, const Response& r) {
  if (r.ok()) {
    if (const auto* ack = r.get<protocol::Ack>()) last_state_ = ack->state;
    return true;
  }
  add_row(step, r, std::nan(""), std::nan(""), response_text(step, r));
  fail(response_text(step, r), r.outcome != Outcome::kRefused);
  return false;
}

TraceRow Rehearsal::row_now(const std::string& step, const std::string& state) const {
  TraceRow row;
  row.seed = scenario_.seed;
  row.t_s = std::chrono::duration<double>(Clock::now() - start_).count();
  row.step = step;
  row.state = state;
  row.base_yaw_rad = pose_.yaw_rad;
  row.true_yaw_error_rad = world_.true_yaw_error_rad(pose_.yaw_rad);
  return row;
}

void Rehearsal::add_row(const std::string& step, const Response& r, double truth, double measured,
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

void Rehearsal::add_state_row(const std::string& step, const std::string& note) {
  TraceRow row = row_now(step, std::string(protocol::to_string(last_state_)));
  row.note = note;
  std::lock_guard lock(telemetry_mutex_);
  telemetry_rows_.push_back(row);
}

void Rehearsal::check_tolerances() {
  auto check = [&](const char* what, double error, double tol) {
    if (!(std::abs(error) <= tol)) {
      result_.missed.push_back(std::string(what) + " error " + fixed(error, 5, true) + " beyond " +
                               fixed(tol, 5));
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

}  // namespace ajar::client::simulation
