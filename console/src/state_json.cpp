// The console's state as the page's JSON: the {"type":"state"} snapshot (connection, Welcome,
// Status, calibration, frame source, features, model, picks, results, last command) that the tick
// broadcasts and /api/state serves, and /api/sim/landmarks (the simulated door's ground truth).
#include "server_impl.hpp"

#include <array>
#include <cmath>
#include <cstdio>

#include "ajar/client/json.hpp"
#include "ajar/protocol/message_table.hpp"
#include "daemon_json.hpp"

namespace ajar::console {

using client::JsonObject;

namespace {
// The page's ops that send a request to ajard (docs/console.md), with that request's type: whether
// an op needs the controller role is that request's row of the message table (message_table.hpp),
// which the page reads from the state's "controller_only" (an observer's buttons for it are off).
struct PageOp {
  std::string_view op;
  protocol::MessageType request;
};
constexpr PageOp kPageOps[] = {
    {"send", protocol::MessageType::kMeasureDoorWidth},  // and the step's other measurements
    {"align", protocol::MessageType::kAlignBase},
    {"engage", protocol::MessageType::kEngage},
    {"reset", protocol::MessageType::kReset},
    {"drive", protocol::MessageType::kDrive},
    {"approach", protocol::MessageType::kApproach},
    {"stop", protocol::MessageType::kStop},
    {"estop", protocol::MessageType::kEmergencyStop},
    {"save_recording", protocol::MessageType::kSaveRecording},
};
static_assert(std::size(kPageOps) > 0);

JsonObject controller_only_json() {
  JsonObject o;
  for (const PageOp& p : kPageOps)
    o.add(p.op, protocol::needs_controller(p.request));
  return o;
}
}  // namespace

// One frame's age, pose and the picks' markers on it: each pick seen from the frame's pose (its
// pixel), and its place by the daemon's staleness rule; "out" when it is not in this image.
std::string ConsoleServer::Impl::frame_json(const FrameEntry& f) const {
  JsonObject o;
  o.add("type", "frame")
      .add("seq", static_cast<std::uint64_t>(static_cast<std::uint32_t>(f.frame.sequence)))
      .add("age_ms", std::chrono::duration<double, std::milli>(Clock::now() - f.captured).count())
      .add("pose_known",
           f.pose_from != Clock::time_point{} && f.captured - f.pose_from <= kFrozenAfter)
      .add("pose", client::JsonArray().add(f.pose.x_m).add(f.pose.y_m).add(f.pose.yaw_rad));
  const core::PlanarPose at_frame{f.pose.x_m, f.pose.y_m, f.pose.yaw_rad};
  const JsonObject markers = board.markers_json(at_frame, f.frame.intrinsics, board_view());
  o.add("markers", markers);
  return o.str();
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
  // The daemon's messages as client::message_json() writes them (wire names, as ajarctl --json).
  const std::uint8_t minor = welcome ? welcome->version_minor : protocol::kVersionMinor;
  if (welcome) {
    o.add("welcome", client::message_json(*welcome, minor));
  } else {
    o.add_null("welcome");
  }
  if (status) {
    o.add("status", status_json(*status, minor));
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
  o.add("controller_only", controller_only_json());
  if (model) {
    o.add("model", client::message_json(*model, minor));  // all of RobotModel, wire names
  } else {
    o.add_null("model");
  }
  // Honest state: the role the daemon gives this session now, who controls, what moves, how old
  // the daemon's telemetry is, the watchdog's threshold (the page's FROZEN).
  o.add("role", role_now ? std::string(protocol::to_string(*role_now)) : std::string());
  o.add("controller", controller_text);
  o.add("motion", motion);
  o.add("frozen_after_ms", static_cast<double>(kFrozenAfter.count()));
  if (!frames.empty()) {
    const auto& k = frames.back()->frame.intrinsics;
    o.add("intrinsics", JsonObject()
                            .add("fx_px", k.fx_px)
                            .add("fy_px", k.fy_px)
                            .add("cx_px", k.cx_px)
                            .add("cy_px", k.cy_px)
                            .add("width_px", k.width_px)
                            .add("height_px", k.height_px));
  }
  o.add("guidance", guidance_json());
  o.add("active_step", kStepNames[board.active()]);
  BoardView view = board_view();
  view.now.reset();  // the picks' places: to the newest telemetry, however old
  if (telemetry) {
    view.now = core::PlanarPose{telemetry->odometry_x_m, telemetry->odometry_y_m,
                                telemetry->base_yaw_odometry_rad};
  }
  o.add("picks", board.picks_json(view));
  o.add("results", board.results_json());
  o.add("recorder", recorder_state);
  if (recorder_save.empty()) {
    o.add_null("recorder_save");
  } else {
    o.add("recorder_save", recorder_save);
  }
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

namespace ajar::console {

// The door points this console measured and the daemon accepted, seen from the base now.
std::vector<Landmark> ConsoleServer::Impl::landmarks_now(const core::PlanarPose& now) const {
  std::vector<Landmark> out;
  if (!camera_to_base) return out;
  const auto add = [&](Step step, std::size_t i, const char* name) {
    const auto& sent = board.sent(step);
    if (!sent || sent->camera_m.size() <= i) return;
    out.push_back(
        {name, core::rebase(camera_to_base->to_base(sent->camera_m[i]), sent->pose, now)});
  };
  add(kWidth, 0, "hinge edge (P1)");
  add(kWidth, 1, "moving edge (P2)");
  add(kHandle, 0, "handle axis");
  add(kHandle, 1, "handle free end");
  return out;
}

// Geometry guidance (issue 23): the door distance, where each measured landmark leaves the view on
// a straight Approach, the standoff that keeps them all in view, the hinge cross-check, and picks
// far off the fitted door plane or outside the measured edges.
JsonObject ConsoleServer::Impl::guidance_json() const {
  JsonObject g;
  if (!telemetry || !camera_to_base || !model || frames.empty()) return g;
  const core::PlanarPose now{telemetry->odometry_x_m, telemetry->odometry_y_m,
                             telemetry->base_yaw_odometry_rad};
  const auto landmarks = landmarks_now(now);
  const double lowest = model->approach_min_standoff_m;
  constexpr double kPreferredStandoff_m = 0.75;  // the paper's standoff for the handle
  if (telemetry->door.has_distance) {
    const double distance = telemetry->door.distance_m;
    g.add("door_distance_m", distance);
    const Camera cam{frames.back()->frame.intrinsics, *camera_to_base, model->min_depth_m,
                     model->max_depth_m};
    const auto limits = view_limits(cam, landmarks, distance, lowest);
    client::JsonArray items;
    for (const auto& l : limits) {
      JsonObject j;
      j.add("name", l.name).add("why", l.why);
      if (std::isfinite(l.min_standoff_m)) {
        j.add("min_standoff_m", l.min_standoff_m);
      } else {
        j.add_null("min_standoff_m");  // out of view already
      }
      items.add(j);
    }
    g.add("view", items);
    if (!landmarks.empty()) {
      g.add("default_standoff_m", default_standoff(limits, lowest, kPreferredStandoff_m, distance));
    }
  }
  // Hinge side: the handle's axis (accepted, or picked and not sent yet) must lie nearer P2 (the
  // moving edge) than P1.
  const auto picks = [this](Step step) -> const std::vector<Pick>& { return board.picks(step); };
  const auto sent = [this](Step step) -> const std::optional<SentStep>& {
    return board.sent(step);
  };
  if (landmarks.size() >= 2 && sent(kWidth)) {
    std::optional<core::Vec3> axis;
    if (sent(kHandle) && landmarks.size() >= 3) axis = landmarks[2].base_m;
    if (!picks(kHandle).empty()) {
      const auto& p = picks(kHandle)[0];
      axis = core::rebase(camera_to_base->to_base(p.camera_m), p.pose, now);
    }
    if (axis) {
      g.add("hinge_problem", hinge_side_problem(landmarks[0].base_m, landmarks[1].base_m, *axis));
    }
  }
  // Picks to look at again: plane points far off the plane of the others or outside the door's
  // measured edges; width points off the accepted door plane.
  client::JsonArray flags;
  const auto flag = [&](Step step, std::size_t i, const std::string& text) {
    flags.add(JsonObject().add("step", kStepNames[step]).add("index", i).add("text", text));
  };
  const auto base_now = [&](const Pick& p) {
    return core::rebase(camera_to_base->to_base(p.camera_m), p.pose, now);
  };
  constexpr double kOffPlane_m = 0.02;
  std::array<char, 200> buf{};
  if (picks(kPlane).size() >= 4) {
    std::vector<core::Vec3> pts;
    for (const auto& p : picks(kPlane))
      pts.push_back(base_now(p));
    for (std::size_t i = 0; i < pts.size(); ++i) {
      std::vector<core::Vec3> others = pts;
      others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
      const auto plane = fit_points(others);
      if (!plane) continue;
      const double d = distance_to_plane(*plane, pts[i]);
      if (d > std::max(kOffPlane_m, 4 * plane->rms_residual_m)) {
        std::snprintf(buf.data(), buf.size(),
                      "point %zu is %.3f m off the plane of the others (handle, frame, wall?)",
                      i + 1, d);
        flag(kPlane, i, buf.data());
      }
    }
  }
  if (landmarks.size() >= 2 && sent(kWidth)) {
    for (std::size_t i = 0; i < picks(kPlane).size(); ++i) {
      const double t =
          along_edges(landmarks[0].base_m, landmarks[1].base_m, base_now(picks(kPlane)[i]));
      if (t < -0.02 || t > 1.02) {
        std::snprintf(buf.data(), buf.size(),
                      "point %zu is outside the door's measured edges (P1..P2): on the wall?",
                      i + 1);
        flag(kPlane, i, buf.data());
      }
    }
  }
  if (sent(kPlane) && sent(kPlane)->camera_m.size() >= 3) {
    std::vector<core::Vec3> pts;
    for (const auto& c : sent(kPlane)->camera_m)
      pts.push_back(core::rebase(camera_to_base->to_base(c), sent(kPlane)->pose, now));
    if (const auto plane = fit_points(pts)) {
      for (std::size_t i = 0; i < picks(kWidth).size(); ++i) {
        const double d = distance_to_plane(*plane, base_now(picks(kWidth)[i]));
        if (d > kOffPlane_m) {
          std::snprintf(buf.data(), buf.size(),
                        "P%zu is %.3f m off the door plane: not on the door leaf's edge?", i + 1,
                        d);
          flag(kWidth, i, buf.data());
        }
      }
    }
  }
  g.add("flags", flags);
  return g;
}

}  // namespace ajar::console
