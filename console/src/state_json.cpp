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

// `key`: what `to_json` makes of `value`; null when there is no value.
template <typename T, typename ToJson>
void add_or_null(JsonObject& o, std::string_view key, const std::optional<T>& value,
                 ToJson to_json) {
  if (value) {
    o.add(key, to_json(*value));
  } else {
    o.add_null(key);
  }
}

// `key`: `value`; null while it is empty (nothing said yet).
void add_or_null(JsonObject& o, std::string_view key, const JsonObject& value) {
  if (value.empty()) {
    o.add_null(key);
  } else {
    o.add(key, value);
  }
}

// The daemon's camera-to-base calibration, row-major 4x4.
client::JsonArray calibration_json(const core::CameraToBase& camera_to_base) {
  client::JsonArray m;
  const Eigen::Matrix4d t = camera_to_base.isometry().matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c)
      m.add(t(r, c));
  }
  return m;
}

// The frame source: what it is, its last error; with a frame (`newest`), its size and rate.
JsonObject source_json(const FrameSource& source, const std::string& error, bool simulated,
                       const FrameEntry* newest) {
  JsonObject src;
  src.add("describe", source.describe()).add("error", error).add("simulated", simulated);
  if (newest != nullptr) {
    src.add("width_px", newest->frame.intrinsics.width_px)
        .add("height_px", newest->frame.intrinsics.height_px)
        .add("rate_hz", source.rate_hz());
  }
  return src;
}

// The newest frame's camera intrinsics.
JsonObject intrinsics_json(const core::PinholeIntrinsics& k) {
  return JsonObject()
      .add("fx_px", k.fx_px)
      .add("fy_px", k.fy_px)
      .add("cx_px", k.cx_px)
      .add("cy_px", k.cy_px)
      .add("width_px", k.width_px)
      .add("height_px", k.height_px);
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
  o.add("connection",
        JsonObject()
            .add("connected", daemon_connected)
            .add("daemon", options.daemon.host + ":" + std::to_string(options.daemon.port))
            .add("message", connection_message)
            .add("heartbeat", heartbeat_on));
  // The daemon's messages as client::message_json() writes them (wire names, as ajarctl --json).
  const std::uint8_t minor = welcome ? welcome->version_minor : protocol::kVersionMinor;
  add_or_null(o, "welcome", welcome, [&](const auto& w) { return client::message_json(w, minor); });
  add_or_null(o, "status", status, [&](const auto& s) { return status_json(s, minor); });
  add_or_null(o, "camera_to_base", camera_to_base, calibration_json);
  o.add("source", source_json(*source, source_error, sim != nullptr,
                              frames.empty() ? nullptr : frames.back().get()));
  // Approach and jog: protocol 1.1 and a daemon that drives (a drive command timeout in its
  // model); otherwise the page shows no such buttons.
  JsonObject features;
  features.add("drive", welcome && welcome->version_minor >= 1 && model &&
                            model->drive_command_timeout_s > 0);
  o.add("features", features);
  o.add("controller_only", controller_only_json());
  add_or_null(o, "model", model, [&](const auto& m) {
    return client::message_json(m, minor);  // all of RobotModel, wire names
  });
  // Honest state: the role the daemon gives this session now, who controls, what moves, how old
  // the daemon's telemetry is, the watchdog's threshold (the page's FROZEN).
  o.add("role", role_now ? std::string(protocol::to_string(*role_now)) : std::string());
  o.add("controller", controller_text);
  o.add("motion", motion);
  o.add("frozen_after_ms", static_cast<double>(kFrozenAfter.count()));
  if (!frames.empty()) o.add("intrinsics", intrinsics_json(frames.back()->frame.intrinsics));
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
  add_or_null(o, "recorder_save", recorder_save);
  add_or_null(o, "last_command", last_command);
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

namespace {
// The view along a straight Approach from the door distance now: where each landmark leaves the
// view, and the standoff that keeps them all in it.
void add_view_guidance(JsonObject& g, const Camera& cam, const std::vector<Landmark>& landmarks,
                       double distance_m, double lowest_m) {
  constexpr double kPreferredStandoff_m = 0.75;  // the paper's standoff for the handle
  const auto limits = view_limits(cam, landmarks, distance_m, lowest_m);
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
    g.add("default_standoff_m",
          default_standoff(limits, lowest_m, kPreferredStandoff_m, distance_m));
  }
}

// Hinge side: the handle's axis (accepted, or picked and not sent yet) must lie nearer P2 (the
// moving edge) than P1. Where that axis is, seen from the base now; nullopt when not measured.
std::optional<core::Vec3> handle_axis_now(const PickBoard& board,
                                          const core::CameraToBase& camera_to_base,
                                          const std::vector<Landmark>& landmarks,
                                          const core::PlanarPose& now) {
  std::optional<core::Vec3> axis;
  if (board.sent(kHandle) && landmarks.size() >= 3) axis = landmarks[2].base_m;
  if (!board.picks(kHandle).empty()) {
    const auto& p = board.picks(kHandle)[0];
    axis = core::rebase(camera_to_base.to_base(p.camera_m), p.pose, now);
  }
  return axis;
}

// Picks to look at again, each with the step, its index and why: seen from the base now.
class PickFlags {
 public:
  PickFlags(const PickBoard& board, const core::CameraToBase& camera_to_base,
            const core::PlanarPose& now)
      : board_(board), camera_to_base_(camera_to_base), now_(now) {}

  // Plane points far off the plane of the others (the handle, the frame, the wall).
  void plane_points_off_their_plane() {
    const auto& picks = board_.picks(kPlane);
    if (picks.size() < 4) return;
    std::vector<core::Vec3> pts;
    for (const auto& p : picks)
      pts.push_back(base_now(p));
    for (std::size_t i = 0; i < pts.size(); ++i) {
      std::vector<core::Vec3> others = pts;
      others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
      const auto plane = fit_points(others);
      if (!plane) continue;
      const double d = distance_to_plane(*plane, pts[i]);
      if (d > std::max(kOffPlane_m, 4 * plane->rms_residual_m)) {
        std::snprintf(buf_.data(), buf_.size(),
                      "point %zu is %.3f m off the plane of the others (handle, frame, wall?)",
                      i + 1, d);
        flag(kPlane, i, buf_.data());
      }
    }
  }
  // Plane points outside the door's measured edges P1..P2 (at base `p1_m`, `p2_m`).
  void plane_points_outside_edges(const core::Vec3& p1_m, const core::Vec3& p2_m) {
    const auto& picks = board_.picks(kPlane);
    for (std::size_t i = 0; i < picks.size(); ++i) {
      const double t = along_edges(p1_m, p2_m, base_now(picks[i]));
      if (t < -0.02 || t > 1.02) {
        std::snprintf(buf_.data(), buf_.size(),
                      "point %zu is outside the door's measured edges (P1..P2): on the wall?",
                      i + 1);
        flag(kPlane, i, buf_.data());
      }
    }
  }
  // Width points off the accepted door plane (not on the door leaf's edge).
  void width_points_off_door_plane() {
    const auto& plane_sent = board_.sent(kPlane);
    if (!plane_sent || plane_sent->camera_m.size() < 3) return;
    std::vector<core::Vec3> pts;
    for (const auto& c : plane_sent->camera_m)
      pts.push_back(core::rebase(camera_to_base_.to_base(c), plane_sent->pose, now_));
    const auto plane = fit_points(pts);
    if (!plane) return;
    const auto& picks = board_.picks(kWidth);
    for (std::size_t i = 0; i < picks.size(); ++i) {
      const double d = distance_to_plane(*plane, base_now(picks[i]));
      if (d > kOffPlane_m) {
        std::snprintf(buf_.data(), buf_.size(),
                      "P%zu is %.3f m off the door plane: not on the door leaf's edge?", i + 1, d);
        flag(kWidth, i, buf_.data());
      }
    }
  }
  const client::JsonArray& json() const { return flags_; }

 private:
  static constexpr double kOffPlane_m = 0.02;

  core::Vec3 base_now(const Pick& p) const {
    return core::rebase(camera_to_base_.to_base(p.camera_m), p.pose, now_);
  }
  void flag(Step step, std::size_t i, const char* text) {
    flags_.add(JsonObject().add("step", kStepNames[step]).add("index", i).add("text", text));
  }

  const PickBoard& board_;
  const core::CameraToBase& camera_to_base_;
  core::PlanarPose now_;
  std::array<char, 200> buf_{};  // a flag's text
  client::JsonArray flags_;
};
}  // namespace

// Geometry guidance (issue 23): the door distance, where each measured landmark leaves the view on
// a straight Approach, the standoff that keeps them all in view, the hinge cross-check, and picks
// far off the fitted door plane or outside the measured edges.
JsonObject ConsoleServer::Impl::guidance_json() const {
  JsonObject g;
  if (!telemetry || !camera_to_base || !model || frames.empty()) return g;
  const core::PlanarPose now{telemetry->odometry_x_m, telemetry->odometry_y_m,
                             telemetry->base_yaw_odometry_rad};
  const auto landmarks = landmarks_now(now);
  if (telemetry->door.has_distance) {
    const double distance = telemetry->door.distance_m;
    g.add("door_distance_m", distance);
    const Camera cam{frames.back()->frame.intrinsics, *camera_to_base, model->min_depth_m,
                     model->max_depth_m};
    add_view_guidance(g, cam, landmarks, distance, model->approach_min_standoff_m);
  }
  // Both door edges seen from the base now: P1 and P2 accepted.
  const bool edges_known = landmarks.size() >= 2 && board.sent(kWidth);
  if (edges_known) {
    if (const auto axis = handle_axis_now(board, *camera_to_base, landmarks, now)) {
      g.add("hinge_problem", hinge_side_problem(landmarks[0].base_m, landmarks[1].base_m, *axis));
    }
  }
  // Picks to look at again: plane points far off the plane of the others or outside the door's
  // measured edges; width points off the accepted door plane.
  PickFlags flags(board, *camera_to_base, now);
  flags.plane_points_off_their_plane();
  if (edges_known) flags.plane_points_outside_edges(landmarks[0].base_m, landmarks[1].base_m);
  flags.width_points_off_door_plane();
  g.add("flags", flags.json());
  return g;
}

}  // namespace ajar::console
