#include <cmath>
#include <numbers>
#include <set>
#include <stdexcept>
#include <string>

#include <yaml-cpp/yaml.h>

#include "ajar/client/simulate.hpp"

namespace ajar::client {
namespace {

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

// door: which side its hinge is, its size, where it stands, its handle.
void read_door(const YamlReader& r, const YAML::Node& door, Scenario& s) {
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
}

// sensor: the depth camera's noise, focal length, and how far inside the edges it picks.
void read_sensor(const YamlReader& r, const YAML::Node& sensor, Scenario& s) {
  r.check_keys(sensor, "sensor",
               {"depth_noise_at_1m_m", "pixel_noise_px", "focal_length_px", "edge_inset_m"});
  r.number(sensor["depth_noise_at_1m_m"], "sensor.depth_noise_at_1m_m", s.depth_noise_at_1m_m, 0,
           0.1);
  r.number(sensor["pixel_noise_px"], "sensor.pixel_noise_px", s.pixel_noise_px, 0, 50);
  r.number(sensor["focal_length_px"], "sensor.focal_length_px", s.focal_length_px, 50, 5000);
  r.number(sensor["edge_inset_m"], "sensor.edge_inset_m", s.edge_inset_m, 0, 0.2);
}

// operator: the height where the operator picks the width, how many plane points.
void read_operator(const YamlReader& r, const YAML::Node& op, Scenario& s) {
  r.check_keys(op, "operator", {"width_pick_height_m", "plane_points"});
  r.number(op["width_pick_height_m"], "operator.width_pick_height_m", s.width_pick_height_m, -3, 3);
  r.integer(op["plane_points"], "operator.plane_points", s.plane_points, 3, 16);
}

// run: the seed and how many alignments are allowed.
void read_run(const YamlReader& r, const YAML::Node& run, Scenario& s) {
  r.check_keys(run, "run", {"seed", "max_align_iterations"});
  double seed = static_cast<double>(s.seed);
  r.number(run["seed"], "run.seed", seed, 0, 4294967295.0);
  s.seed = static_cast<std::uint64_t>(seed);
  r.integer(run["max_align_iterations"], "run.max_align_iterations", s.max_align_iterations, 1, 10);
}

// tolerances: how far each result may be from the world's truth.
void read_tolerances(const YamlReader& r, const YAML::Node& tol, Scenario& s) {
  r.check_keys(tol, "tolerances",
               {"width_m", "handle_length_m", "residual_yaw_rad", "contact_m", "standoff_m"});
  r.number(tol["standoff_m"], "tolerances.standoff_m", s.standoff_tolerance_m, 0, 1);
  r.number(tol["width_m"], "tolerances.width_m", s.width_tolerance_m, 0, 1);
  r.number(tol["handle_length_m"], "tolerances.handle_length_m", s.handle_tolerance_m, 0, 1);
  r.number(tol["residual_yaw_rad"], "tolerances.residual_yaw_rad", s.residual_yaw_tolerance_rad, 0,
           1);
  r.number(tol["contact_m"], "tolerances.contact_m", s.contact_tolerance_m, 0, 1);
}

// drive: the jog and the two Approach standoffs, the wheels' slip and the encoders' noise.
void read_drive(const YamlReader& r, const YAML::Node& drive, Scenario& s) {
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
  read_door(r, root["door"], s);
  if (const auto sensor = root["sensor"]) read_sensor(r, sensor, s);
  if (const auto op = root["operator"]) read_operator(r, op, s);
  if (const auto run = root["run"]) read_run(r, run, s);
  if (const auto tol = root["tolerances"]) read_tolerances(r, tol, s);
  if (const auto drive = root["drive"]) read_drive(r, drive, s);
  if (const auto expect = root["expect"]) {
    r.check_keys(expect, "expect", {"engaged"});
    if (expect["engaged"]) s.expect_engaged = expect["engaged"].as<bool>();
  }
  return s;
}

}  // namespace ajar::client
