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
    daemon_connected = true;
    connection_message = "connected";
    heartbeat_on = false;  // re-evaluated on the next tick for this connection
    add_log("connected to ajard " + std::string(w.daemon_version.view()) + " as " +
            std::string(protocol::to_string(w.granted_role)) + " (protocol " +
            std::to_string(w.version_major) + "." + std::to_string(w.version_minor) + ")");
    mark_dirty();
  });
  refresh_status();
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
  add_log("calibration from ajard: camera -> base (eq. 1)");
  mark_dirty();
}

void ConsoleServer::Impl::idle() {
  if (!client.connected() && Clock::now() >= next_connect_attempt) connect_now();
}

void ConsoleServer::Impl::on_telemetry(const protocol::Telemetry& t) {
  {
    const std::lock_guard lock(pose_mutex);
    pose.x_m = t.odometry_x_m;
    pose.y_m = t.odometry_y_m;
    pose.yaw_rad = t.base_yaw_odometry_rad;
  }
  const std::string json = telemetry_json(t).str();
  on_io([this, json] { broadcast_text(json); });
}

void ConsoleServer::Impl::on_event(const protocol::Event& e) {
  std::string text = "event " + std::string(protocol::to_string(e.kind)) + ": " +
                     std::string(protocol::to_string(e.state));
  if (e.fault != ErrorCode::kOk) text += " fault " + std::string(ajar::to_string(e.fault));
  if (!e.detail.view().empty()) text += " (" + std::string(e.detail.view()) + ")";
  on_io([this, text] { add_log(text); });
  worker->post([this] { refresh_status(); });
}

}  // namespace ajar::console
