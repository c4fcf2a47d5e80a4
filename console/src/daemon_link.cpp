// The console's side of ajard: DaemonLink (daemon_link.hpp) on its worker threads: connect (Hello
// as controller, or as observer when another controller holds the robot; reconnect once a second),
// Subscribe, the robot model (calibration), Status after every request and event; and what the
// console makes of it, of telemetry and of events (the client's reader), on the Asio thread
// (on_io).
#include "server_impl.hpp"

#include <utility>

#include "ajar/client/json.hpp"
#include "daemon_json.hpp"

namespace ajar::console {

DaemonLink::DaemonLink(const ConsoleOptions& options, Listener& listener)
    : options_(options),
      listener_(listener),
      client_(client::ClientOptions{std::chrono::milliseconds(2000),
                                    std::chrono::milliseconds(3000), 1, 0, "ajar-console",
                                    options.tls}),
      role_(options.role),
      take_over_next_(options.take_over) {}

DaemonLink::~DaemonLink() {
  shutdown();
}

void DaemonLink::start() {
  worker_ = std::make_unique<Worker>([this] { idle(); });
  stop_worker_ = std::make_unique<Worker>();
  worker_->post([this] { connect_now(); });
}

void DaemonLink::shutdown() {
  if (worker_) worker_->shutdown();
  if (stop_worker_) stop_worker_->shutdown();
  client_.set_heartbeat(std::chrono::milliseconds(0));
  client_.close();
}

void DaemonLink::post(Job job) {
  worker_->post(std::move(job));
}

void DaemonLink::post_stop(Job job) {
  stop_worker_->post(std::move(job));
}

void DaemonLink::take_over() {
  worker_->post([this] {
    client_.close();
    role_ = protocol::Role::kController;
    take_over_next_ = true;
    connect_now();
  });
}

void DaemonLink::observe() {
  worker_->post([this] {
    client_.close();
    role_ = protocol::Role::kObserver;
    connect_now();
  });
}

void DaemonLink::demoted() {
  worker_->post([this] { role_ = protocol::Role::kObserver; });
}

void DaemonLink::drive(const protocol::Drive& d,
                       std::function<void(const client::Response&)> refused) {
  bool post = false;
  {
    const std::lock_guard lock(drive_mutex_);
    pending_drive_ = d;
    post = !drive_queued_;
    drive_queued_ = true;
  }
  if (!post) return;
  worker_->post([this, refused = std::move(refused)] {
    protocol::Drive newest;
    {
      const std::lock_guard lock(drive_mutex_);
      newest = pending_drive_;
      drive_queued_ = false;
    }
    const auto r = client_.request(newest, std::chrono::milliseconds(300), 0);
    if (!r.ok()) refused(r);
  });
}

void DaemonLink::refresh_status() {
  const auto r = client_.request(protocol::GetStatus{}, std::chrono::milliseconds(1000), 0);
  if (const auto* st = r.get<protocol::Status>()) listener_.status_received(*st);
}

void DaemonLink::connect_now() {
  next_connect_attempt_ = Clock::now() + std::chrono::seconds(1);
  if (const auto connected = client_.connect(options_.daemon); !connected) {
    listener_.connect_failed(connected.error().message);
    return;
  }
  auto r = client_.hello(role_, take_over_next_);
  if (r.outcome == client::CallOutcome::kRefused && r.error.code == ErrorCode::kControllerBusy) {
    // Someone else controls the robot: watch as an observer; the page offers take-over.
    client_.close();
    if (!client_.connect(options_.daemon)) return;
    r = client_.hello(protocol::Role::kObserver, false);
  }
  take_over_next_ = false;
  if (!r.ok()) {
    const std::string why = "Hello refused: " + response_json(r).str();
    client_.close();
    listener_.hello_refused(why);
    return;
  }
  const auto w = *client_.welcome();
  client_.request(protocol::Subscribe{options_.telemetry_rate_hz});
  if (w.version_minor >= 1) listener_.robot_model(client_.request(protocol::GetRobotModel{}));
  listener_.connected(w);
  refresh_status();
  listener_.worker_idle(true);
}

void DaemonLink::idle() {
  if (!client_.connected() && Clock::now() >= next_connect_attempt_) connect_now();
  listener_.worker_idle(false);
}

// ---- the console's side: what the link learns, on the Asio thread ----

void ConsoleServer::Impl::connect_failed(const std::string& why) {
  on_io([this, why] {
    if (connection_message != why) add_log("ajard: " + why);
    daemon_connected = false;
    connection_message = why;
    mark_dirty();
  });
}

void ConsoleServer::Impl::hello_refused(const std::string& why) {
  on_io([this, why] {
    add_log(why);
    connection_message = why;
    mark_dirty();
  });
}

void ConsoleServer::Impl::robot_model(const client::Response& reply) {
  if (const auto* m = reply.get<protocol::RobotModel>()) {
    on_io([this, copy = *m] { set_model(copy); });
  } else {
    on_io([this, reply] { log_response("GetRobotModel", reply); });
  }
}

void ConsoleServer::Impl::connected(const protocol::Welcome& w) {
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
}

void ConsoleServer::Impl::worker_idle(bool connected_now) {
  if (connected_now || Clock::now() >= next_recorder_poll) refresh_recorder();
}

void ConsoleServer::Impl::status_received(const protocol::Status& s) {
  recorder_status(s);
  on_io([this, s] {
    status = s;
    if (foxglove) foxglove->on_status(s);
    mark_dirty();
  });
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
  on_io([this, t, now] {
    // In the layout of the session's minor (welcome: this thread's), as ajarctl prints it.
    const std::string json =
        telemetry_json(t, welcome ? welcome->version_minor : protocol::kVersionMinor).str();
    const bool stale_changed = !telemetry || telemetry->staleness.plane != t.staleness.plane ||
                               telemetry->staleness.contact != t.staleness.contact ||
                               telemetry->moving != t.moving;
    telemetry = t;
    telemetry_at = now;
    pages.broadcast_text(json);
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
    link.post([this, e] {
      const auto w = link.client().welcome();
      on_io([this, e, id = w ? w->session_id : 0] { on_event_io(e, id); });
      link.refresh_status();
    });
    return;
  }
  on_io([this, e] { on_event_io(e, 0); });
  link.post([this] { link.refresh_status(); });
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
          link.demoted();  // a reconnect stays so
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
