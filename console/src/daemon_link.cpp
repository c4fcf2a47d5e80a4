// The console's side of ajard, on the worker threads: connect (Hello as controller, or as observer
// when another controller holds the robot; reconnect once a second), Subscribe, the robot model
// (calibration), Status after every request and event; telemetry and events from the client's
// reader. Results reach the Asio thread's state through on_io.
#include "server_impl.hpp"

#include "ajar/client/json.hpp"
#include "daemon_json.hpp"

namespace ajar::console {

void ConsoleServer::Impl::refresh_status() {
  const auto r = client.request(protocol::GetStatus{}, std::chrono::milliseconds(1000), 0);
  if (const auto* st = r.get<protocol::Status>()) {
    const protocol::Status copy = *st;
    on_io([this, copy] {
      status = copy;
      if (foxglove) foxglove->on_status(copy);
      mark_dirty();
    });
  }
}

void ConsoleServer::Impl::connect_now() {
  next_connect_attempt = Clock::now() + std::chrono::seconds(1);
  if (const auto connected = client.connect(options.daemon); !connected) {
    on_io([this, err = connected.error().message] {
      if (connection_message != err) add_log("ajard: " + err);
      daemon_connected = false;
      connection_message = err;
      mark_dirty();
    });
    return;
  }
  auto r = client.hello(role, take_over_next);
  if (r.outcome == client::CallOutcome::kRefused && r.error.code == ErrorCode::kControllerBusy) {
    // Someone else controls the robot: watch as an observer; the page offers take-over.
    client.close();
    if (!client.connect(options.daemon)) return;
    r = client.hello(protocol::Role::kObserver, false);
  }
  take_over_next = false;
  if (!r.ok()) {
    const std::string why = "Hello refused: " + response_json(r).str();
    client.close();
    on_io([this, why] {
      add_log(why);
      connection_message = why;
      mark_dirty();
    });
    return;
  }
  const auto w = *client.welcome();
  client.request(protocol::Subscribe{options.telemetry_rate_hz});
  if (w.version_minor >= 1) {
    const auto rm = client.request(protocol::GetRobotModel{});
    if (const auto* m = rm.get<protocol::RobotModel>()) {
      const protocol::RobotModel copy = *m;
      on_io([this, copy] { set_model(copy); });
    } else {
      on_io([this, rm] { log_response("GetRobotModel", rm); });
    }
  }
  on_io([this, w] {
    welcome = w;
    role_now = w.granted_role;
    controller_text.clear();
    motion.clear();
    daemon_connected = true;
    connection_message = "connected";
    heartbeat_on = false;  // re-evaluated on the next tick for this connection
    add_log("connected to ajard " + std::string(w.daemon_version.view()) + " as " +
            std::string(protocol::to_string(w.granted_role)) + " (protocol " +
            std::to_string(w.version_major) + "." + std::to_string(w.version_minor) + ")");
    mark_dirty();
  });
  refresh_status();
  refresh_recorder();
}

// The daemon's calibration: base-frame coordinates on the page and the simulated camera's mount.
void ConsoleServer::Impl::set_model(const protocol::RobotModel& m) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c)
      t(r, c) = m.camera_to_base[static_cast<std::size_t>(r * 4 + c)];
  }
  auto checked = core::CameraToBase::from_matrix(t);
  if (!checked) {
    add_log("ajard's camera_to_base refused: " + checked.error().message);
    return;
  }
  camera_to_base = *checked;
  model = m;
  if (sim != nullptr) sim->set_camera_to_base(t);
  if (foxglove) foxglove->on_model(m);
  add_log("calibration from ajard: camera -> base (eq. 1)");
  mark_dirty();
}

void ConsoleServer::Impl::idle() {
  if (!client.connected() && Clock::now() >= next_connect_attempt) connect_now();
  if (Clock::now() >= next_recorder_poll) refresh_recorder();
}

void ConsoleServer::Impl::on_telemetry(const protocol::Telemetry& t) {
  const auto now = Clock::now();
  {
    const std::lock_guard lock(pose_mutex);
    pose.x_m = t.odometry_x_m;
    pose.y_m = t.odometry_y_m;
    pose.yaw_rad = t.base_yaw_odometry_rad;
    pose_at = now;
  }
  if (foxglove) foxglove->on_telemetry(t);
  const std::string json = telemetry_json(t).str();
  on_io([this, json, t, now] {
    const bool stale_changed = !telemetry || telemetry->staleness.plane != t.staleness.plane ||
                               telemetry->staleness.contact != t.staleness.contact ||
                               telemetry->moving != t.moving;
    telemetry = t;
    telemetry_at = now;
    broadcast_text(json);
    // The picks' places (moved, stale) and the guidance follow the pose: a new snapshot when the
    // base moved (at most 10 per second: the tick).
    const core::PlanarPose p{t.odometry_x_m, t.odometry_y_m, t.base_yaw_odometry_rad};
    if (stale_changed || core::travel_m(broadcast_pose, p) > kPickMovedTravel_m ||
        std::abs(core::turn_rad(broadcast_pose, p)) > kPickMovedTurn_rad) {
      mark_dirty();
    }
  });
}

void ConsoleServer::Impl::on_event(const protocol::Event& e) {
  if (e.kind == protocol::EventKind::kControlChanged) {
    // Compared with this session's id once the Hello that may have caused it has returned (the
    // worker runs connect_now to its end first).
    worker->post([this, e] {
      const auto w = client.welcome();
      on_io([this, e, id = w ? w->session_id : 0] { on_event_io(e, id); });
      refresh_status();
    });
    return;
  }
  on_io([this, e] { on_event_io(e, 0); });
  worker->post([this] { refresh_status(); });
}

namespace {
// "session 7 (ajarctl) took control from session 3 (ajar-console)", "session 3 (ajar-console) is
// the controller" (docs/protocol.md, control_changed): the session that controls now, if named.
std::optional<std::uint64_t> controller_session(std::string_view detail) {
  constexpr std::string_view kSession = "session ";
  if (detail.substr(0, kSession.size()) != kSession) return std::nullopt;
  if (detail.find(" took control from ") == std::string_view::npos &&
      detail.find(" is the controller") == std::string_view::npos) {
    return std::nullopt;
  }
  std::uint64_t id = 0;
  std::size_t i = kSession.size();
  if (i >= detail.size() || detail[i] < '0' || detail[i] > '9') return std::nullopt;
  for (; i < detail.size() && detail[i] >= '0' && detail[i] <= '9'; ++i)
    id = id * 10 + static_cast<std::uint64_t>(detail[i] - '0');
  return id;
}
}  // namespace

// The event log in the operator's words ("fault latched: EMERGENCY_STOPPED (...)"), the motion the
// header shows, and the role: a control_changed naming another session as controller demotes this
// one (the daemon made it an observer, docs/protocol.md 6.2).
void ConsoleServer::Impl::on_event_io(const protocol::Event& e, std::uint64_t session_id) {
  using protocol::EventKind;
  const std::string detail(e.detail.view());
  const std::string state(protocol::to_string(e.state));
  if (foxglove) foxglove->on_event(e);
  std::string text;
  switch (e.kind) {
    case EventKind::kStateChanged:
      text = "state: " + state;
      break;
    case EventKind::kMotionStarted: {
      text = "motion started: " + detail;
      const auto word = detail.substr(0, detail.find(':'));
      motion = word == "driving" ? "jogging" : word.empty() ? "moving" : word;
      break;
    }
    case EventKind::kMotionFinished:
      text = "motion finished: " + detail;
      motion.clear();
      break;
    case EventKind::kMotionStopped:
      text = "motion stopped: " + detail;
      motion.clear();
      break;
    case EventKind::kFaultLatched:
      text = "FAULT LATCHED: " + std::string(ajar::to_string(e.fault)) +
             (detail.empty() ? "" : " (" + detail + ")");
      motion.clear();
      break;
    case EventKind::kFaultCleared:
      text = "fault cleared" + (detail.empty() ? "" : ": " + detail);
      break;
    case EventKind::kControlChanged: {
      controller_text = detail;
      text = "control: " + detail;
      const auto controller = controller_session(detail);
      if (controller && session_id != 0) {
        const auto was = role_now;
        role_now =
            *controller == session_id ? protocol::Role::kController : protocol::Role::kObserver;
        if (was == protocol::Role::kController && role_now == protocol::Role::kObserver) {
          text += ": this console is now an OBSERVER (Take over to command again)";
          worker->post([this] { role = protocol::Role::kObserver; });  // a reconnect stays so
        }
      }
      break;
    }
  }
  add_log(text);
  mark_dirty();
}

void ConsoleServer::Impl::on_reply(const client::Response& r) {
  if (r.outcome == client::CallOutcome::kRefused && r.error.code == ErrorCode::kNotController &&
      role_now != protocol::Role::kObserver) {
    role_now = protocol::Role::kObserver;
    add_log("ajard says this console is not the controller: it is an OBSERVER now");
    mark_dirty();
  }
}

}  // namespace ajar::console
