// The console's state as the page's JSON: the {"type":"state"} snapshot (connection, Welcome,
// Status, calibration, frame source, features, model, picks, results, last command) that the tick
// broadcasts and /api/state serves, and /api/sim/landmarks (the simulated door's ground truth).
#include "server_impl.hpp"

#include "ajar/client/json.hpp"
#include "daemon_json.hpp"

namespace ajar::console {

using client::JsonObject;

JsonObject ConsoleServer::Impl::picks_json() const {
  JsonObject o;
  for (std::size_t s = 0; s < kStepCount; ++s) {
    client::JsonArray items;
    for (const auto& p : picks[s]) {
      JsonObject j;
      j.add("u", p.u_px)
          .add("v", p.v_px)
          .add("camera_m", p.camera_m)
          .add("from_window", p.from_window);
      if (camera_to_base) j.add("base_m", camera_to_base->to_base(p.camera_m));
      items.add(j);
    }
    o.add(kStepNames[s], items);
  }
  return o;
}

JsonObject ConsoleServer::Impl::results_json() const {
  JsonObject o;
  for (std::size_t s = 0; s < kStepCount; ++s) {
    if (!results[s].empty()) o.add(kStepNames[s], results[s]);
  }
  return o;
}

std::string ConsoleServer::Impl::snapshot() const {
  JsonObject o;
  o.add("type", "state");
  JsonObject conn;
  conn.add("connected", daemon_connected)
      .add("daemon", options.daemon.host + ":" + std::to_string(options.daemon.port))
      .add("message", connection_message)
      .add("heartbeat", heartbeat_on);
  o.add("connection", conn);
  if (welcome) {
    JsonObject w;
    w.add("role", protocol::to_string(welcome->granted_role))
        .add("version_major", static_cast<int>(welcome->version_major))
        .add("version_minor", static_cast<int>(welcome->version_minor))
        .add("daemon_version", welcome->daemon_version.view())
        .add("loop_rate_hz", welcome->loop_rate_hz)
        .add("deadman_timeout_s", welcome->deadman_timeout_s)
        .add("min_door_width_m", welcome->min_door_width_m)
        .add("max_door_width_m", welcome->max_door_width_m)
        .add("min_handle_length_m", welcome->min_handle_length_m)
        .add("max_handle_length_m", welcome->max_handle_length_m)
        .add("max_yaw_correction_rad", welcome->max_yaw_correction_rad)
        .add("driver_kind", protocol::to_string(welcome->driver_kind));
    o.add("welcome", w);
  } else {
    o.add_null("welcome");
  }
  if (status) {
    o.add("status", status_json(*status));
  } else {
    o.add_null("status");
  }
  if (camera_to_base) {
    client::JsonArray m;  // row-major 4x4
    const Eigen::Matrix4d t = camera_to_base->isometry().matrix();
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c)
        m.add(t(r, c));
    }
    o.add("camera_to_base", m);
  } else {
    o.add_null("camera_to_base");
  }
  JsonObject src;
  src.add("describe", source->describe())
      .add("error", source_error)
      .add("simulated", sim != nullptr);
  if (!frames.empty()) {
    src.add("width_px", frames.back()->frame.intrinsics.width_px)
        .add("height_px", frames.back()->frame.intrinsics.height_px)
        .add("rate_hz", source->rate_hz());
  }
  o.add("source", src);
  // Approach and jog: protocol 1.1 and a daemon that drives (a drive command timeout in its
  // model); otherwise the page shows no such buttons.
  JsonObject features;
  features.add("drive", welcome && welcome->version_minor >= 1 && model &&
                            model->drive_command_timeout_s > 0);
  o.add("features", features);
  if (model) {
    JsonObject m;
    m.add("max_linear_speed_m_s", model->max_linear_speed_m_s)
        .add("max_angular_speed_rad_s", model->max_angular_speed_rad_s)
        .add("drive_command_timeout_s", model->drive_command_timeout_s)
        .add("approach_min_standoff_m", model->approach_min_standoff_m)
        .add("min_depth_m", model->min_depth_m)
        .add("max_depth_m", model->max_depth_m)
        .add("aligned_tolerance_rad", model->aligned_tolerance_rad);
    o.add("model", m);
  } else {
    o.add_null("model");
  }
  o.add("active_step", kStepNames[active]);
  o.add("picks", picks_json());
  o.add("results", results_json());
  if (last_command.empty()) {
    o.add_null("last_command");
  } else {
    o.add("last_command", last_command);
  }
  return o.str();
}

std::string ConsoleServer::Impl::landmarks_json() const {
  if (sim == nullptr || frames.empty()) return "null";
  const auto& entry = *frames.back();
  const auto& scene = sim->scene();
  const auto l = scene.landmarks();
  const Eigen::Isometry3d cam = DoorScene::camera_in_world(entry.pose, sim->camera_to_base());
  const Eigen::Isometry3d world_to_cam = cam.inverse();
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(core::Vec3(entry.pose.x_m, entry.pose.y_m, 0));
  base.rotate(Eigen::AngleAxisd(entry.pose.yaw_rad, core::Vec3::UnitZ()));
  const Eigen::Isometry3d world_to_base = base.inverse();
  JsonObject pts;
  const std::array<std::pair<const char*, core::Vec3>, 8> named{
      {{"hinge_edge", l.hinge_edge},
       {"moving_edge", l.moving_edge},
       {"handle_axis", l.handle_axis},
       {"handle_free_end", l.handle_free_end},
       {"contact", l.contact},
       {"leaf_low_left", l.leaf_low_left},
       {"leaf_low_right", l.leaf_low_right},
       {"leaf_high_middle", l.leaf_high_middle}}};
  for (const auto& [name, world] : named) {
    const core::Vec3 c = world_to_cam * world;
    const auto px = core::project(entry.frame.intrinsics, c);
    JsonObject p;
    p.add("camera_m", c).add("base_m", core::Vec3(world_to_base * world));
    if (px) p.add("u", px->u_px).add("v", px->v_px);
    pts.add(name, p);
  }
  const auto& s = scene.scenario();
  JsonObject truth;
  truth.add("width_m", s.door_width_m)
      .add("handle_length_m", s.handle_length_m)
      .add("direction", s.hinge == client::Scenario::Hinge::kLeft ? "CCW" : "CW")
      .add("yaw_to_square_rad", s.yaw_rad - entry.pose.yaw_rad)
      .add("depth_noise_at_1m_m", scene.sensor().depth_noise_at_1m_m);
  return JsonObject()
      .add("sequence", static_cast<std::uint64_t>(entry.frame.sequence))
      .add("base_yaw_rad", entry.pose.yaw_rad)
      .add("points", pts)
      .add("truth", truth)
      .str();
}

}  // namespace ajar::console
