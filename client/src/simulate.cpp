#include "ajar/client/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <ostream>
#include <stdexcept>

#include <CLI/CLI.hpp>

#include "ajar/client/cli.hpp"
#include "ajar/client/output.hpp"
#include "ajar/daemon/config.hpp"
#include "simulate_detail.hpp"

namespace ajar::client {
namespace {

using simulation::RunResult;
using simulation::TraceRow;

// ---- Statistics and reports
// ------------------------------------------------------------------------

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
  JsonArray missed;
  for (const auto& m : r.missed)
    missed.add(m);
  o.add("missed", missed);
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

namespace {

// `ajarctl simulate SCENARIO.yaml [--seeds N] [--seed S] [--plane-points N] [--trace FILE]
// [--config FILE]` (docs/ajarctl.md).
struct SimulateArgs {
  std::string scenario_path, trace_path, config_path;
  int seeds = 1;
  int plane_points = 0;  // 0: the scenario's
  std::optional<std::uint64_t> seed;
};

// Empty, or what is wrong with `args` (the words after `simulate`).
std::string parse_simulate_args(const std::vector<std::string>& args, SimulateArgs& a) {
  CLI::App app("", "simulate");
  app.set_help_flag();  // `simulate --help` is answered before (cli_help.cpp)
  app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  app.add_option("scenario", a.scenario_path)->type_name("SCENARIO.yaml");
  app.add_option("--trace", a.trace_path)->type_name("FILE");
  app.add_option("--config", a.config_path)->type_name("FILE");
  app.add_option("--seeds", a.seeds, "runs, seeds S, S+1, ...")->check(CLI::Range(1, 100000));
  app.add_option("--plane-points", a.plane_points)->check(CLI::Range(3, 16));
  app.add_option_function<std::uint64_t>(
         "--seed", [&a](const std::uint64_t& seed) { a.seed = seed; }, "the first seed")
      ->check(CLI::Validator(  // CLI11 2.1 reads "-3" as 2^64 - 3
          [](std::string& v) -> std::string {
            return v.find('-') == std::string::npos ? "" : "wants a whole number, got '" + v + "'";
          },
          "S"));
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them reversed
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    return e.what();
  }
  if (a.scenario_path.empty()) return "simulate wants SCENARIO.yaml";
  return {};
}

// What the runs of one `simulate` found: its statistics over the seeds.
struct SimulateRuns {
  int passed = 0;
  bool connection_failed = false;
  std::vector<double> yaw_before_error, yaw_after;
};

// The scenario's seeds rehearsed against ajard, one report each (stops at a lost connection).
SimulateRuns rehearse_seeds(const Scenario& scenario, const Eigen::Matrix4d& camera_to_base,
                            int seeds, const GlobalOptions& options, std::vector<TraceRow>& trace,
                            std::ostream& out) {
  SimulateRuns runs;
  for (int i = 0; i < seeds; ++i) {
    Scenario run_scenario = scenario;
    run_scenario.seed = scenario.seed + static_cast<std::uint64_t>(i);
    bool lost = false;
    const RunResult result =
        simulation::rehearse(run_scenario, camera_to_base, options, trace, lost);
    if (result.ok()) ++runs.passed;
    // Every run that got as far as an alignment counts in the statistics (also one that the
    // daemon never accepted as aligned).
    if (result.align_iterations > 0) {
      runs.yaw_before_error.push_back(result.yaw_before_measured_rad - result.yaw_before_true_rad);
      runs.yaw_after.push_back(result.yaw_after_true_rad);
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
    if (lost) {
      runs.connection_failed = true;
      break;
    }
  }
  return runs;
}

// The summary of several seeds (JSON or text).
void print_summary(const Scenario& scenario, int seeds, const SimulateRuns& runs, bool json,
                   std::ostream& out) {
  const auto& before = runs.yaw_before_error;
  const auto& after = runs.yaw_after;
  if (json) {
    JsonObject o;
    o.add("type", "simulate_summary").add("command", "simulate").add("ok", runs.passed == seeds);
    o.add("scenario", scenario.name).add("plane_points", scenario.plane_points);
    o.add("runs", seeds).add("passed", runs.passed);
    o.add("yaw_error_before_rms_rad", rms(before))
        .add("yaw_error_before_max_abs_rad", max_abs(before));
    o.add("residual_yaw_rms_rad", rms(after))
        .add("residual_yaw_mean_abs_rad", mean_abs(after))
        .add("residual_yaw_max_abs_rad", max_abs(after));
    out << o.str() << '\n';
    return;
  }
  out << scenario.name << ": " << runs.passed << "/" << seeds << " runs passed, "
      << scenario.plane_points << " plane points\n"
      << "  first plane yaw error (measured - true): rms " << fixed(rms(before), 5)
      << " rad, max |.| " << fixed(max_abs(before), 5) << " rad\n"
      << "  residual yaw after alignment (true):     rms " << fixed(rms(after), 5)
      << " rad, mean |.| " << fixed(mean_abs(after), 5) << " rad, max |.| "
      << fixed(max_abs(after), 5) << " rad\n";
}

}  // namespace

int run_simulate(const Command& command, const GlobalOptions& options, std::ostream& out,
                 std::ostream& err) {
  SimulateArgs a;
  if (const std::string problem = parse_simulate_args(command.args, a); !problem.empty()) {
    err << "ajarctl: simulate: " << problem << '\n';
    return kExitUsage;
  }
  Scenario scenario;
  Eigen::Matrix4d camera_to_base;
  try {
    scenario = load_scenario(a.scenario_path);
    camera_to_base = a.config_path.empty() ? core::paper_camera_to_base_m()
                                           : daemon::load_config(a.config_path).camera_to_base_m;
  } catch (const std::exception& e) {
    err << "ajarctl: simulate: " << e.what() << '\n';
    return kExitUsage;
  }
  if (a.seed) scenario.seed = *a.seed;
  if (a.plane_points != 0) scenario.plane_points = a.plane_points;

  std::vector<TraceRow> trace;
  const SimulateRuns runs = rehearse_seeds(scenario, camera_to_base, a.seeds, options, trace, out);
  if (a.seeds > 1) print_summary(scenario, a.seeds, runs, options.json, out);
  if (!a.trace_path.empty()) {
    try {
      write_trace(a.trace_path, trace);
    } catch (const std::exception& e) {
      err << "ajarctl: simulate: " << e.what() << '\n';
      return kExitUsage;
    }
  }
  if (runs.connection_failed) return kExitConnection;
  return runs.passed == a.seeds ? kExitOk : kExitRefused;
}

}  // namespace ajar::client
