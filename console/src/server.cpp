#include "ajar/console/server.hpp"

// <utility> before any Asio header (asio issue 944).
#include <utility>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/redirect_error.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/use_awaitable.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "ajar/client/json.hpp"
#include "ajar/console/door_scene.hpp"
#include "ajar/console/image_io.hpp"
#include "ajar/console/page_message.hpp"
#include "ajar/core/geometry.hpp"
#include "ajar/security/tls_files.hpp"

namespace ajar::console {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;
using boost::system::error_code;
using client::json_number;
using client::json_string;
using client::json_vec3;
using client::JsonObject;
using Clock = std::chrono::steady_clock;

// ---- Steps of the parameter region ----------------------------------------------------------

enum Step : std::size_t { kWidth = 0, kHandle = 1, kPlane = 2, kContact = 3, kStepCount = 4 };
constexpr std::array<const char*, kStepCount> kStepNames{"width", "handle", "plane", "contact"};
constexpr std::array<std::size_t, kStepCount> kStepCapacity{2, 2, protocol::kMaxPlanePoints, 1};

std::optional<Step> step_from(const std::string& name) {
  for (std::size_t i = 0; i < kStepCount; ++i) {
    if (name == kStepNames[i]) return static_cast<Step>(i);
  }
  return std::nullopt;
}

struct Pick {
  double u_px = 0;
  double v_px = 0;
  core::Vec3 camera_m = core::Vec3::Zero();
  bool from_window = false;
};

std::string json_array(const std::vector<std::string>& items) {
  std::string out = "[";
  for (std::size_t i = 0; i < items.size(); ++i) {
    if (i > 0) out += ",";
    out += items[i];
  }
  return out + "]";
}

std::string error_name(ErrorCode code) {
  return std::string(ajar::to_string(code));
}

std::string span_json(const protocol::SpanAck& a) {
  return JsonObject()
      .add("length_m", a.length_m)
      .add("direction", core::to_string(a.direction))
      .add("p1_base_m", a.p1_base_m)
      .add("p2_base_m", a.p2_base_m)
      .str();
}
std::string plane_json(const protocol::PlaneAck& a) {
  return JsonObject()
      .add("normal", a.normal)
      .add("yaw_deviation_rad", a.yaw_deviation_rad)
      .add("left_wheel_rad", a.left_wheel_rad)
      .add("right_wheel_rad", a.right_wheel_rad)
      .add("left_counts", static_cast<std::int64_t>(a.left_counts))
      .add("right_counts", static_cast<std::int64_t>(a.right_counts))
      .add("residual_yaw_rad", a.residual_yaw_rad)
      .add("rms_residual_m", a.rms_residual_m)
      .add("point_count", static_cast<int>(a.point_count))
      .str();
}
std::string contact_json(const protocol::ContactAck& a) {
  return JsonObject()
      .add("contact_base_m", a.contact_base_m)
      .add("reach_margin_m", a.reach_margin_m)
      .str();
}

// The reply to a request as the page shows it: {"ok":true,"values":{...}} or
// {"ok":false,"code":"POINTS_COLLINEAR","field":"points[2]","message":"..."}.
std::string response_json(const client::Response& r) {
  JsonObject o;
  if (r.outcome == client::Outcome::kReply) {
    o.add("ok", true);
    if (const auto* ack = r.get<protocol::Ack>()) {
      o.add("state", protocol::to_string(ack->state));
      if (const auto* s = std::get_if<protocol::SpanAck>(&ack->body))
        o.add_raw("values", span_json(*s));
      if (const auto* p = std::get_if<protocol::PlaneAck>(&ack->body))
        o.add_raw("values", plane_json(*p));
      if (const auto* c = std::get_if<protocol::ContactAck>(&ack->body)) {
        o.add_raw("values", contact_json(*c));
      }
    }
    return o.str();
  }
  o.add("ok", false);
  if (r.outcome == client::Outcome::kRefused) {
    o.add("code", error_name(r.error.code));
    o.add("field", r.error.field.view());
    o.add("message", r.error.message.view());
  } else {
    o.add("code", client::to_string(r.outcome));
    o.add("field", "");
    o.add("message", r.transport_error);
  }
  return o.str();
}

std::string loop_json(const protocol::LoopStatistics& l) {
  return JsonObject()
      .add("rate_hz", l.rate_hz)
      .add("cycles", l.cycles)
      .add("overruns", l.overruns)
      .add("period_p50_ns", static_cast<std::uint64_t>(l.period_p50_ns))
      .add("period_p99_ns", static_cast<std::uint64_t>(l.period_p99_ns))
      .add("period_max_ns", static_cast<std::uint64_t>(l.period_max_ns))
      .add("jitter_p99_ns", static_cast<std::uint64_t>(l.jitter_p99_ns))
      .str();
}

std::string status_json(const protocol::Status& s) {
  JsonObject o;
  o.add("state", protocol::to_string(s.state));
  o.add("latched_fault", error_name(s.latched_fault));
  o.add("controller_connected", s.controller_connected);
  o.add("session_count", static_cast<int>(s.session_count));
  o.add("restored_from_disk", s.restored_from_disk);
  if (s.has_width) o.add_raw("width", span_json(s.width));
  if (s.has_handle) o.add_raw("handle", span_json(s.handle));
  if (s.has_plane) o.add_raw("plane", plane_json(s.plane));
  if (s.has_contact) o.add_raw("contact", contact_json(s.contact));
  o.add("base_yaw_odometry_rad", s.base_yaw_odometry_rad);
  o.add("card", protocol::to_string(s.card));
  o.add("arm", protocol::to_string(s.arm));
  o.add("arm_state", protocol::to_string(s.arm_state));
  o.add_raw("loop", loop_json(s.loop));
  return o.str();
}

std::string telemetry_json(const protocol::Telemetry& t) {
  return JsonObject()
      .add("type", "telemetry")
      .add("t_s", static_cast<double>(t.daemon_time_ns) * 1e-9)
      .add("state", protocol::to_string(t.state))
      .add("moving", t.moving)
      .add("left_wheel_rad", t.left_wheel_rad)
      .add("right_wheel_rad", t.right_wheel_rad)
      .add("left_counts", static_cast<std::int64_t>(t.left_counts))
      .add("right_counts", static_cast<std::int64_t>(t.right_counts))
      .add("base_yaw_odometry_rad", t.base_yaw_odometry_rad)
      .add("odometry_x_m", t.odometry_x_m)
      .add("odometry_y_m", t.odometry_y_m)
      .add("door_has_distance", t.door.has_distance)
      .add("door_distance_m", t.door.distance_m)
      .add("door_has_yaw", t.door.has_yaw)
      .add("door_yaw_rad", t.door.yaw_rad)
      .add("plane_stale", t.staleness.plane)
      .add("contact_stale", t.staleness.contact)
      .add("commanded_linear_m_s", t.commanded_linear_m_s)
      .add("commanded_angular_rad_s", t.commanded_angular_rad_s)
      .add("arm_state", protocol::to_string(t.arm_state))
      .add_raw("loop", loop_json(t.loop))
      .str();
}

std::string now_hms() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  std::array<char, 16> buf{};
  std::strftime(buf.data(), buf.size(), "%H:%M:%S", &tm);
  return buf.data();
}

// Depth colourised for the overlay: near red .. far blue over the sensor's range, holes magenta.
Rgb8Image colourise_depth(const Frame& f) {
  Rgb8Image img{f.intrinsics.width_px, f.intrinsics.height_px, {}};
  img.rgb.resize(f.depth_m.size() * 3);
  for (std::size_t i = 0; i < f.depth_m.size(); ++i) {
    const double d = f.depth_m[i];
    std::array<double, 3> c{255, 0, 255};
    if (d > 0) {
      const double x = std::clamp((d - 0.4) / 3.6, 0.0, 1.0);
      c = {255 * std::clamp(1.5 - 3 * x, 0.0, 1.0),
           255 * std::clamp(1.5 - std::abs(3 * x - 1.5), 0.0, 1.0),
           255 * std::clamp(3 * x - 1.5, 0.0, 1.0)};
    }
    for (std::size_t ch = 0; ch < 3; ++ch)
      img.rgb[i * 3 + ch] = static_cast<std::uint8_t>(c[ch]);
  }
  return img;
}

// Binary frame message: u8 kind (1 colour, 2 depth overlay), u32 sequence (big-endian), PNG.
std::shared_ptr<const std::string> frame_message(std::uint8_t kind, std::uint64_t sequence,
                                                 const std::vector<std::uint8_t>& png) {
  auto msg = std::make_shared<std::string>();
  msg->reserve(png.size() + 5);
  msg->push_back(static_cast<char>(kind));
  const auto seq = static_cast<std::uint32_t>(sequence);
  for (int shift = 24; shift >= 0; shift -= 8) {
    msg->push_back(static_cast<char>((seq >> shift) & 0xFFU));
  }
  msg->append(reinterpret_cast<const char*>(png.data()), png.size());
  return msg;
}

struct FrameEntry {
  Frame frame;
  BasePose pose;
  std::shared_ptr<const std::string> colour;
  std::shared_ptr<const std::string> depth;  // null when no page asked for the overlay
};

// A queue of jobs on one thread.
class Worker {
 public:
  using Job = std::function<void()>;
  explicit Worker(std::function<void()> idle = {}) : idle_(std::move(idle)) {
    thread_ = std::thread([this] { loop(); });
  }
  ~Worker() { shutdown(); }
  void post(Job job) {
    {
      const std::lock_guard lock(mutex_);
      jobs_.push_back(std::move(job));
    }
    cv_.notify_one();
  }
  void shutdown() {
    {
      const std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_one();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void loop() {
    std::unique_lock lock(mutex_);
    while (!stopping_) {
      if (jobs_.empty()) {
        cv_.wait_for(lock, std::chrono::milliseconds(300));
        if (jobs_.empty()) {
          if (idle_ && !stopping_) {
            lock.unlock();
            idle_();
            lock.lock();
          }
          continue;
        }
      }
      Job job = std::move(jobs_.front());
      jobs_.pop_front();
      lock.unlock();
      job();
      lock.lock();
    }
  }
  std::function<void()> idle_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> jobs_;
  bool stopping_ = false;
  std::thread thread_;
};

struct WsSession {
  explicit WsSession(tcp::socket socket) : ws(std::move(socket)), wake(ws.get_executor()) {}
  websocket::stream<tcp::socket> ws;
  asio::steady_timer wake;
  struct Outgoing {
    bool binary = false;
    std::shared_ptr<const std::string> data;
  };
  std::deque<Outgoing> queue;
  int frames_queued = 0;
  bool closed = false;
  bool overlay = false;
  Clock::time_point last_alive{};
};

std::string content_type(const std::string& name) {
  const auto ext = std::filesystem::path(name).extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  return "application/octet-stream";
}

bool safe_file_name(const std::string& name) {
  if (name.empty() || name[0] == '.') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '-' || c == '_';
  });
}

}  // namespace

// ---- The console --------------------------------------------------------------------------------

struct ConsoleServer::Impl {
  Impl(ConsoleOptions o, std::unique_ptr<FrameSource> s, SimulatedSource* sim_source)
      : options(std::move(o)),
        source(std::move(s)),
        sim(sim_source),
        acceptor(ioc),
        client(client::ClientOptions{std::chrono::milliseconds(2000),
                                     std::chrono::milliseconds(3000), 1, 0, "ajar-console",
                                     options.tls}),
        role(options.role),
        take_over_next(options.take_over) {}

  ConsoleOptions options;
  std::unique_ptr<FrameSource> source;
  SimulatedSource* sim;
  asio::io_context ioc{1};
  tcp::acceptor acceptor;
  std::uint16_t port = 0;
  client::Client client;

  // ---- State owned by the Asio thread ----
  std::set<std::shared_ptr<WsSession>> sessions;
  std::deque<std::shared_ptr<const FrameEntry>> frames;  // newest last
  std::string source_error;
  bool daemon_connected = false;
  std::string connection_message = "connecting";
  std::optional<protocol::Welcome> welcome;
  std::optional<protocol::Status> status;
  std::optional<core::CameraToBase> camera_to_base;  // from the daemon (RobotModel)
  std::optional<protocol::RobotModel> model;         // protocol 1.1: GetRobotModel
  std::array<std::vector<Pick>, kStepCount> picks;
  std::array<std::string, kStepCount> results;  // JSON, empty when nothing sent yet
  std::string last_command;                     // JSON of the last command's reply
  Step active = kWidth;
  std::deque<std::string> log;
  bool heartbeat_on = false;
  bool state_dirty = true;

  // ---- Shared with the frame thread ----
  std::mutex pose_mutex;
  BasePose pose;
  std::atomic<bool> overlay_wanted{false};
  std::atomic<bool> any_page{false};
  std::atomic<bool> stopping{false};
  std::thread frame_thread;

  // ---- Daemon side (worker threads) ----
  protocol::Role role;  // worker thread only
  bool take_over_next;  // worker thread only
  Clock::time_point next_connect_attempt{};
  std::unique_ptr<Worker> worker;       // connect, measurements, commands
  std::unique_ptr<Worker> stop_worker;  // Stop and EmergencyStop only
  // Jog: the newest Drive the page asked for; one job at a time carries the latest to ajard.
  std::mutex drive_mutex;
  protocol::Drive pending_drive;
  bool drive_queued = false;

  // ---------------------------------------------------------------------------------------------
  // Posting to the Asio thread.
  template <typename F>
  void on_io(F&& f) {
    asio::post(ioc, std::forward<F>(f));
  }

  void add_log(const std::string& text) {
    const std::string entry = now_hms() + "  " + text;
    log.push_back(entry);
    while (log.size() > 200)
      log.pop_front();
    broadcast_text(
        JsonObject().add("type", "log").add_raw("entries", json_array({json_string(entry)})).str());
  }

  // ---- Snapshot -------------------------------------------------------------------------------
  std::string picks_json() const {
    JsonObject o;
    for (std::size_t s = 0; s < kStepCount; ++s) {
      std::vector<std::string> items;
      for (const auto& p : picks[s]) {
        JsonObject j;
        j.add("u", p.u_px)
            .add("v", p.v_px)
            .add("camera_m", p.camera_m)
            .add("from_window", p.from_window);
        if (camera_to_base) j.add("base_m", camera_to_base->to_base(p.camera_m));
        items.push_back(j.str());
      }
      o.add_raw(kStepNames[s], json_array(items));
    }
    return o.str();
  }
  std::string results_json() const {
    JsonObject o;
    for (std::size_t s = 0; s < kStepCount; ++s) {
      if (!results[s].empty()) o.add_raw(kStepNames[s], results[s]);
    }
    return o.str();
  }
  std::string snapshot() const {
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
      o.add_raw("welcome", "null");
    }
    o.add_raw("status", status ? status_json(*status) : "null");
    if (camera_to_base) {
      std::vector<std::string> m;
      const Eigen::Matrix4d t = camera_to_base->isometry().matrix();
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c)
          m.push_back(json_number(t(r, c)));
      }
      o.add_raw("camera_to_base", json_array(m));
    } else {
      o.add_raw("camera_to_base", "null");
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
    // Drive/Approach arrive with protocol 1.1 and the driving work; until then: no such buttons.
    // Approach and jog: protocol 1.1 and a daemon that drives (a drive command timeout in its
    // model).
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
      o.add_raw("model", "null");
    }
    o.add("active_step", kStepNames[active]);
    o.add_raw("picks", picks_json());
    o.add_raw("results", results_json());
    o.add_raw("last_command", last_command.empty() ? "null" : last_command);
    return o.str();
  }

  // ---- Sending to pages ------------------------------------------------------------------------
  void enqueue(const std::shared_ptr<WsSession>& s, bool binary,
               std::shared_ptr<const std::string> data) {
    if (s->closed || !data) return;
    if (binary) {
      if (s->frames_queued >= 2) return;  // a slow page skips frames, never text
      ++s->frames_queued;
    }
    s->queue.push_back({binary, std::move(data)});
    s->wake.cancel();
  }
  void broadcast_text(const std::string& text) {
    const auto data = std::make_shared<const std::string>(text);
    for (const auto& s : sessions)
      enqueue(s, false, data);
  }
  void mark_dirty() { state_dirty = true; }

  // ---- HTTP ------------------------------------------------------------------------------------
  bool host_allowed(const http::request<http::string_body>& req) const {
    const std::string host(req[http::field::host]);
    const std::string p = ":" + std::to_string(port);
    return host == "127.0.0.1" + p || host == "localhost" + p || host == "[::1]" + p ||
           host == options.listen_host + p;
  }

  http::response<http::string_body> respond(const http::request<http::string_body>& req,
                                            http::status code, std::string body,
                                            const std::string& type) {
    http::response<http::string_body> res{code, req.version()};
    res.set(http::field::server, "ajar-console");
    res.set(http::field::content_type, type);
    res.set(http::field::cache_control, "no-store");
    res.set("X-Content-Type-Options", "nosniff");
    res.keep_alive(req.keep_alive());
    res.body() = std::move(body);
    res.prepare_payload();
    return res;
  }

  std::string landmarks_json() const {
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

  asio::awaitable<void> serve(tcp::socket socket) {
    beast::flat_buffer buffer;
    for (;;) {
      http::request<http::string_body> req;
      error_code ec;
      http::request_parser<http::string_body> parser;
      parser.body_limit(4096);
      co_await http::async_read(socket, buffer, parser,
                                asio::redirect_error(asio::use_awaitable, ec));
      if (ec) co_return;
      req = parser.release();
      if (!host_allowed(req)) {
        auto res = respond(req, http::status::forbidden, "ajar-console: unexpected Host header\n",
                           "text/plain");
        co_await http::async_write(socket, res, asio::redirect_error(asio::use_awaitable, ec));
        co_return;
      }
      if (websocket::is_upgrade(req)) {
        const std::string origin(req[http::field::origin]);
        const std::string host(req[http::field::host]);
        if (req.target() != "/ws" || (!origin.empty() && origin != "http://" + host)) {
          auto res = respond(req, http::status::forbidden,
                             "ajar-console: WebSocket only at /ws from this console's own page\n",
                             "text/plain");
          co_await http::async_write(socket, res, asio::redirect_error(asio::use_awaitable, ec));
          co_return;
        }
        auto session = std::make_shared<WsSession>(std::move(socket));
        session->ws.read_message_max(8192);
        co_await session->ws.async_accept(req, asio::redirect_error(asio::use_awaitable, ec));
        if (ec) co_return;
        co_await run_session(session);
        co_return;
      }
      http::response<http::string_body> res;
      const std::string target(req.target());
      if (req.method() != http::verb::get && req.method() != http::verb::head) {
        res = respond(req, http::status::method_not_allowed, "GET only\n", "text/plain");
      } else if (target == "/api/state") {
        res = respond(req, http::status::ok, snapshot(), "application/json");
      } else if (target == "/api/sim/landmarks") {
        res = respond(req, sim ? http::status::ok : http::status::not_found, landmarks_json(),
                      "application/json");
      } else {
        const std::string name = target == "/" ? "index.html" : target.substr(1);
        std::string body;
        bool found = false;
        if (safe_file_name(name)) {
          std::ifstream f(std::filesystem::path(options.web_dir) / name, std::ios::binary);
          if (f) {
            std::ostringstream ss;
            ss << f.rdbuf();
            body = ss.str();
            found = true;
          }
        }
        res = found ? respond(req, http::status::ok, std::move(body), content_type(name))
                    : respond(req, http::status::not_found, "not found\n", "text/plain");
      }
      co_await http::async_write(socket, res, asio::redirect_error(asio::use_awaitable, ec));
      if (ec || !req.keep_alive()) co_return;
    }
  }

  asio::awaitable<void> write_loop(std::shared_ptr<WsSession> s) {
    error_code ec;
    while (!s->closed) {
      if (s->queue.empty()) {
        s->wake.expires_at(Clock::time_point::max());
        co_await s->wake.async_wait(asio::redirect_error(asio::use_awaitable, ec));
        continue;
      }
      auto m = std::move(s->queue.front());
      s->queue.pop_front();
      if (m.binary) --s->frames_queued;
      s->ws.binary(m.binary);
      co_await s->ws.async_write(asio::buffer(*m.data),
                                 asio::redirect_error(asio::use_awaitable, ec));
      if (ec) {
        s->closed = true;
        break;
      }
    }
  }

  asio::awaitable<void> run_session(std::shared_ptr<WsSession> s) {
    sessions.insert(s);
    any_page = true;
    enqueue(s, false, std::make_shared<const std::string>(snapshot()));
    std::vector<std::string> entries;
    for (const auto& e : log)
      entries.push_back(json_string(e));
    enqueue(s, false,
            std::make_shared<const std::string>(
                JsonObject().add("type", "log").add_raw("entries", json_array(entries)).str()));
    if (!frames.empty()) enqueue(s, true, frames.back()->colour);
    asio::co_spawn(ioc, write_loop(s), asio::detached);
    beast::flat_buffer buffer;
    for (;;) {
      error_code ec;
      buffer.clear();
      co_await s->ws.async_read(buffer, asio::redirect_error(asio::use_awaitable, ec));
      if (ec) break;
      if (!s->ws.got_text()) continue;
      handle_page(s, beast::buffers_to_string(buffer.data()));
    }
    s->closed = true;
    s->wake.cancel();
    sessions.erase(s);
    any_page = !sessions.empty();
    update_overlay();
    update_heartbeat();  // a closed page stops feeding the deadman at once
  }

  asio::awaitable<void> accept_loop() {
    for (;;) {
      error_code ec;
      tcp::socket socket(ioc);
      co_await acceptor.async_accept(socket, asio::redirect_error(asio::use_awaitable, ec));
      if (ec) {
        if (ec == asio::error::operation_aborted) co_return;
        continue;
      }
      asio::co_spawn(ioc, serve(std::move(socket)), asio::detached);
    }
  }

  // ---- Page messages ---------------------------------------------------------------------------
  void reply(const std::shared_ptr<WsSession>& s, const std::string& text) {
    enqueue(s, false, std::make_shared<const std::string>(text));
  }
  void notice(const std::shared_ptr<WsSession>& s, const std::string& text) {
    reply(s, JsonObject().add("type", "notice").add("text", text).str());
  }

  std::shared_ptr<const FrameEntry> frame_for(const PageMessage& m) const {
    if (frames.empty()) return nullptr;
    if (const auto seq = m.number("seq")) {
      for (const auto& f : frames) {
        if (static_cast<double>(static_cast<std::uint32_t>(f->frame.sequence)) == *seq) return f;
      }
    }
    return frames.back();
  }

  void handle_page(const std::shared_ptr<WsSession>& s, const std::string& text) {
    std::string error;
    const auto m = PageMessage::parse(text, error);
    if (!m) {
      notice(s, error);
      return;
    }
    const std::string op = m->op();
    if (op == "alive") {
      s->last_alive = Clock::now();
      update_heartbeat();
    } else if (op == "overlay") {
      s->overlay = m->flag("on").value_or(false);
      update_overlay();
    } else if (op == "hover") {
      hover(s, *m);
    } else if (op == "step") {
      const auto step = step_from(m->text("step").value_or(""));
      if (!step) return notice(s, "unknown step");
      active = *step;
      mark_dirty();
    } else if (op == "pick") {
      pick(s, *m);
    } else if (op == "rect") {
      rect(s, *m);
    } else if (op == "clear") {
      picks[active].clear();
      results[active].clear();
      mark_dirty();
    } else if (op == "undo") {
      if (!picks[active].empty()) picks[active].pop_back();
      mark_dirty();
    } else if (op == "send") {
      send_step(s);
    } else if (op == "align" || op == "engage" || op == "reset" || op == "stop" || op == "estop") {
      command(op, m->flag("clear").value_or(false));
    } else if (op == "drive") {
      drive(s, *m);
    } else if (op == "approach") {
      const auto standoff = m->number("standoff_m");
      if (!standoff) return notice(s, "approach: standoff_m needed");
      add_log("sending Approach to " + json_number(*standoff) + " m");
      const protocol::Message msg = protocol::Approach{*standoff};
      worker->post([this, msg] {
        const auto r = client.request(msg);
        const auto json = response_json(r);
        on_io([this, json, r] {
          last_command = JsonObject().add("op", "approach").add_raw("reply", json).str();
          log_response("approach", r);
          mark_dirty();
        });
        refresh_status();
      });
    } else if (op == "take_over") {
      add_log("taking over control");
      worker->post([this] {
        client.close();
        role = protocol::Role::kController;
        take_over_next = true;
        connect_now();
      });
    } else if (op == "observe") {
      add_log("switching to observer");
      worker->post([this] {
        client.close();
        role = protocol::Role::kObserver;
        connect_now();
      });
    } else {
      notice(s, "PAGE_MESSAGE: unknown op '" + op + "'");
    }
  }

  // Jog: coalesced, so a slow daemon never sees a backlog of old velocities.
  void drive(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
    const auto linear = m.number("linear");
    const auto angular = m.number("angular");
    if (!linear || !angular) return notice(s, "drive: linear and angular needed");
    bool post = false;
    {
      const std::lock_guard lock(drive_mutex);
      pending_drive = protocol::Drive{*linear, *angular};
      post = !drive_queued;
      drive_queued = true;
    }
    if (!post) return;
    worker->post([this] {
      protocol::Drive d;
      {
        const std::lock_guard lock(drive_mutex);
        d = pending_drive;
        drive_queued = false;
      }
      const auto r = client.request(d, std::chrono::milliseconds(300), 0);
      if (!r.ok()) {
        on_io([this, r] { log_response("drive", r); });
      }
    });
  }

  void hover(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
    const auto u = m.number("u");
    const auto v = m.number("v");
    const auto f = frame_for(m);
    JsonObject o;
    o.add("type", "hover");
    if (!u || !v || !f) {
      o.add("ok", false).add("message", f ? "u and v needed" : "no frame yet");
      return reply(s, o.str());
    }
    o.add("u", *u).add("v", *v);
    const auto p = core::pick_point(f->frame.intrinsics, f->frame.depth(), *u, *v);
    if (!p) {
      o.add("ok", false).add("field", p.error().field).add("message", p.error().message);
      return reply(s, o.str());
    }
    o.add("ok", true)
        .add("camera_m", p->camera_m)
        .add("depth_m", p->depth_m)
        .add("from_window", p->from_window);
    if (camera_to_base) o.add("base_m", camera_to_base->to_base(p->camera_m));
    reply(s, o.str());
  }

  void pick(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
    const auto u = m.number("u");
    const auto v = m.number("v");
    const auto f = frame_for(m);
    if (!u || !v || !f) return notice(s, f ? "pick: u and v needed" : "pick: no frame yet");
    const auto p = core::pick_point(f->frame.intrinsics, f->frame.depth(), *u, *v);
    if (!p) {
      add_log("pick refused: " + p.error().message);
      reply(s, JsonObject()
                   .add("type", "pick_refused")
                   .add("field", p.error().field)
                   .add("message", p.error().message)
                   .str());
      return;
    }
    auto& list = picks[active];
    if (list.size() >= kStepCapacity[active]) {
      if (active == kPlane) {
        return notice(s, "the plane takes at most 16 points: send or clear them");
      }
      list.clear();  // width, handle, contact: a new pick starts over
    }
    list.push_back({*u, *v, p->camera_m, p->from_window});
    results[active].clear();
    mark_dirty();
  }

  // Up to 16 well-spread valid points inside a rectangle: a 4x4 grid of cells, in each the valid
  // pixel nearest the cell's centre (the pick rule's window median for holes).
  void rect(const std::shared_ptr<WsSession>& s, const PageMessage& m) {
    const auto u0 = m.number("u0");
    const auto v0 = m.number("v0");
    const auto u1 = m.number("u1");
    const auto v1 = m.number("v1");
    const auto f = frame_for(m);
    if (!u0 || !v0 || !u1 || !v1 || !f) return notice(s, "rect: u0, v0, u1, v1 needed");
    const double ul = std::min(*u0, *u1);
    const double ur = std::max(*u0, *u1);
    const double vt = std::min(*v0, *v1);
    const double vb = std::max(*v0, *v1);
    std::vector<Pick> found;
    constexpr int kGrid = 4;
    for (int j = 0; j < kGrid; ++j) {
      for (int i = 0; i < kGrid; ++i) {
        const double u = ul + (ur - ul) * (i + 0.5) / kGrid;
        const double v = vt + (vb - vt) * (j + 0.5) / kGrid;
        const auto p = core::pick_point(f->frame.intrinsics, f->frame.depth(), u, v);
        if (p) found.push_back({u, v, p->camera_m, p->from_window});
      }
    }
    if (found.size() < protocol::kMinPlanePoints) {
      add_log("rectangle refused: only " + std::to_string(found.size()) +
              " of 16 points have depth; drag over a measurable part of the door");
      return;
    }
    active = kPlane;
    picks[kPlane] = std::move(found);
    results[kPlane].clear();
    mark_dirty();
  }

  void send_step(const std::shared_ptr<WsSession>& s) {
    const Step step = active;
    const auto& list = picks[step];
    const auto framed = [](const Pick& p) {
      return client::framed(core::Frame::kCamera, p.camera_m.x(), p.camera_m.y(), p.camera_m.z());
    };
    protocol::Message msg;
    switch (step) {
      case kWidth:
        if (list.size() != 2) return notice(s, "width: pick P1 (hinge side) and P2 (moving edge)");
        msg = protocol::MeasureDoorWidth{framed(list[0]), framed(list[1])};
        break;
      case kHandle:
        if (list.size() != 2) return notice(s, "handle: pick the axis, then the free end");
        msg = protocol::MeasureHandle{framed(list[0]), framed(list[1])};
        break;
      case kPlane: {
        if (list.size() < protocol::kMinPlanePoints) {
          return notice(s, "plane: pick at least three points on the door, or drag a rectangle");
        }
        protocol::MeasureDoorPlane plane;
        plane.count = static_cast<std::uint8_t>(list.size());
        for (std::size_t i = 0; i < list.size(); ++i)
          plane.points[i] = framed(list[i]);
        msg = plane;
        break;
      }
      case kContact:
        if (list.size() != 1) return notice(s, "contact: pick the contact point on the handle");
        msg = protocol::SetContactPoint{framed(list[0])};
        break;
      case kStepCount:
        return;
    }
    add_log(std::string("sending ") + std::string(protocol::to_string(protocol::type_of(msg))));
    worker->post([this, step, msg] {
      const auto r = client.request(msg);
      const auto json = response_json(r);
      on_io([this, step, json, r] {
        results[step] = json;
        log_response(std::string(kStepNames[step]), r);
        mark_dirty();
      });
      refresh_status();
    });
  }

  void log_response(const std::string& what, const client::Response& r) {
    if (r.outcome == client::Outcome::kReply) {
      add_log(what + ": accepted");
    } else if (r.outcome == client::Outcome::kRefused) {
      add_log(what + ": refused " + error_name(r.error.code) +
              (r.error.field.view().empty() ? "" : " (" + std::string(r.error.field.view()) + ")") +
              ": " + std::string(r.error.message.view()));
    } else {
      add_log(what + ": " + std::string(client::to_string(r.outcome)) + ": " + r.transport_error);
    }
  }

  void command(const std::string& op, bool clear) {
    protocol::Message msg;
    if (op == "align") msg = protocol::AlignBase{};
    if (op == "engage") msg = protocol::Engage{};
    if (op == "reset") msg = protocol::Reset{clear};
    if (op == "stop") msg = protocol::Stop{};
    if (op == "estop") msg = protocol::EmergencyStop{};
    const bool urgent = op == "stop" || op == "estop";
    add_log(std::string(urgent ? "!! " : "") + "sending " +
            std::string(protocol::to_string(protocol::type_of(msg))) +
            (clear ? " (clear parameters)" : ""));
    if (clear) {
      for (auto& l : picks)
        l.clear();
      for (auto& r : results)
        r.clear();
      active = kWidth;
      mark_dirty();
    }
    auto job = [this, op, msg] {
      const auto r = client.request(msg, std::chrono::milliseconds(1000), 2);
      const auto json = response_json(r);
      on_io([this, op, json, r] {
        last_command = JsonObject().add("op", op).add_raw("reply", json).str();
        log_response(op, r);
        mark_dirty();
      });
      refresh_status();
    };
    (urgent ? stop_worker : worker)->post(std::move(job));
  }

  // ---- Heartbeat (deadman) gating and overlay
  // ----------------------------------------------------
  void update_heartbeat() {
    const auto now = Clock::now();
    bool alive = false;
    for (const auto& s : sessions)
      alive = alive || (now - s->last_alive < kPageAliveTimeout);
    if (alive != heartbeat_on) {
      heartbeat_on = alive;
      std::chrono::milliseconds interval{0};
      if (alive) {
        const double deadman_s = welcome ? static_cast<double>(welcome->deadman_timeout_s) : 1.0;
        interval = std::chrono::milliseconds(
            std::clamp(static_cast<long>(deadman_s * 1000 / 4), 20L, 250L));
      }
      client.set_heartbeat(interval);
      add_log(alive ? "page alive: feeding the deadman" : "no live page: deadman no longer fed");
      mark_dirty();
    }
  }
  void update_overlay() {
    bool want = false;
    for (const auto& s : sessions)
      want = want || s->overlay;
    overlay_wanted = want;
  }

  asio::awaitable<void> tick_loop() {
    asio::steady_timer timer(ioc);
    error_code ec;
    while (!stopping) {
      timer.expires_after(std::chrono::milliseconds(100));
      co_await timer.async_wait(asio::redirect_error(asio::use_awaitable, ec));
      update_heartbeat();
      if (state_dirty) {
        state_dirty = false;
        broadcast_text(snapshot());
      }
    }
  }

  // ---- Daemon side (worker thread) -------------------------------------------------------------
  void refresh_status() {
    const auto r = client.request(protocol::GetStatus{}, std::chrono::milliseconds(1000), 0);
    if (const auto* st = r.get<protocol::Status>()) {
      const protocol::Status copy = *st;
      on_io([this, copy] {
        status = copy;
        mark_dirty();
      });
    }
  }

  void connect_now() {
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
    if (r.outcome == client::Outcome::kRefused && r.error.code == ErrorCode::kControllerBusy) {
      // Someone else controls the robot: watch as an observer; the page offers take-over.
      client.close();
      if (!client.connect(options.daemon)) return;
      r = client.hello(protocol::Role::kObserver, false);
    }
    take_over_next = false;
    if (!r.ok()) {
      const std::string why = "Hello refused: " + response_json(r);
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
  void set_model(const protocol::RobotModel& m) {
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

  void idle() {
    if (!client.connected() && Clock::now() >= next_connect_attempt) connect_now();
  }

  // ---- Frames (frame thread) -------------------------------------------------------------------
  void frame_loop() {
    const double rate = std::clamp(source->rate_hz(), 0.5, 60.0);
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
    auto next = Clock::now();
    std::string last_error;
    while (!stopping) {
      BasePose p;
      {
        const std::lock_guard lock(pose_mutex);
        p = pose;
      }
      auto entry = std::make_shared<FrameEntry>();
      std::string why;
      if (source->next(p, entry->frame, why)) {
        entry->pose = p;
        if (any_page) {
          const auto& k = entry->frame.intrinsics;
          entry->colour = frame_message(
              1, entry->frame.sequence,
              encode_png_rgb8(Rgb8Image{k.width_px, k.height_px, entry->frame.rgb}, 1));
          if (overlay_wanted) {
            entry->depth = frame_message(2, entry->frame.sequence,
                                         encode_png_rgb8(colourise_depth(entry->frame), 1));
          }
        }
        on_io([this, entry] {
          frames.push_back(entry);
          while (frames.size() > 6)
            frames.pop_front();
          if (!source_error.empty()) {
            source_error.clear();
            mark_dirty();
          }
          for (const auto& s : sessions) {
            if (entry->colour) enqueue(s, true, entry->colour);
            if (s->overlay && entry->depth) enqueue(s, true, entry->depth);
          }
        });
        last_error.clear();
      } else if (why != last_error) {
        last_error = why;
        on_io([this, why] {
          source_error = why;
          add_log("camera: " + why);
          mark_dirty();
        });
      }
      next += period;
      const auto now = Clock::now();
      if (next < now) next = now;
      std::this_thread::sleep_until(next);
    }
  }

  void on_telemetry(const protocol::Telemetry& t) {
    {
      const std::lock_guard lock(pose_mutex);
      pose.x_m = t.odometry_x_m;
      pose.y_m = t.odometry_y_m;
      pose.yaw_rad = t.base_yaw_odometry_rad;
    }
    const std::string json = telemetry_json(t);
    on_io([this, json] { broadcast_text(json); });
  }

  void on_event(const protocol::Event& e) {
    std::string text = "event " + std::string(protocol::to_string(e.kind)) + ": " +
                       std::string(protocol::to_string(e.state));
    if (e.fault != ErrorCode::kOk) text += " fault " + error_name(e.fault);
    if (!e.detail.view().empty()) text += " (" + std::string(e.detail.view()) + ")";
    on_io([this, text] { add_log(text); });
    worker->post([this] { refresh_status(); });
  }
};

ConsoleServer::ConsoleServer(ConsoleOptions options, std::unique_ptr<FrameSource> source,
                             SimulatedSource* sim)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(source), sim)) {}

ConsoleServer::~ConsoleServer() {
  stop();
  if (impl_->worker) impl_->worker->shutdown();
  if (impl_->stop_worker) impl_->stop_worker->shutdown();
  if (impl_->frame_thread.joinable()) impl_->frame_thread.join();
  impl_->client.set_heartbeat(std::chrono::milliseconds(0));
  impl_->client.close();
}

std::uint16_t ConsoleServer::listen() {
  auto& d = *impl_;
  // Before anything listens: a bad key is a start-up error, not a retry loop on the page.
  const auto& tls = d.options.tls;
  if (!tls.enabled() && (!tls.certificate.empty() || !tls.private_key.empty()))
    throw std::runtime_error("--cert/--key need --ca (the CA that signed ajard's certificate)");
  if (tls.enabled()) {
    if (tls.certificate.empty() != tls.private_key.empty())
      throw std::runtime_error("TLS: a client certificate needs both --cert and --key");
    const std::pair<const std::string*, const char*> files[] = {
        {&tls.ca, "--ca"}, {&tls.certificate, "--cert"}, {&tls.private_key, "--key"}};
    for (const auto& [path, option] : files) {
      if (path->empty()) continue;
      const std::string problem = security::tls_file_problem(*path, path == &tls.private_key);
      if (!problem.empty()) throw std::runtime_error(std::string(option) + ": " + problem);
    }
  }
  error_code ec;
  const auto address = asio::ip::make_address(d.options.listen_host, ec);
  if (ec)
    throw std::runtime_error("--listen: '" + d.options.listen_host + "' is not an IP address");
  const tcp::endpoint ep(address, d.options.listen_port);
  d.acceptor.open(ep.protocol(), ec);
  if (!ec) d.acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) d.acceptor.bind(ep, ec);
  if (!ec) d.acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error("cannot listen on " + d.options.listen_host + ":" +
                             std::to_string(d.options.listen_port) + ": " + ec.message());
  }
  d.port = d.acceptor.local_endpoint().port();
  return d.port;
}

void ConsoleServer::run() {
  auto& d = *impl_;
  d.client.on_telemetry([&d](const protocol::Telemetry& t) { d.on_telemetry(t); });
  d.client.on_event([&d](const protocol::Event& e) { d.on_event(e); });
  d.client.on_disconnect([&d](const std::string& why) {
    d.on_io([&d, why] {
      d.daemon_connected = false;
      d.connection_message = "disconnected: " + why;
      d.add_log("ajard: disconnected: " + why);
      d.mark_dirty();
    });
  });
  d.add_log("camera: " + d.source->describe());
  d.worker = std::make_unique<Worker>([&d] { d.idle(); });
  d.stop_worker = std::make_unique<Worker>();
  d.worker->post([&d] { d.connect_now(); });
  d.frame_thread = std::thread([&d] { d.frame_loop(); });
  asio::signal_set signals(d.ioc, SIGINT, SIGTERM);
  signals.async_wait([this](const error_code& ec, int) {
    if (!ec) stop();
  });
  asio::co_spawn(d.ioc, d.accept_loop(), asio::detached);
  asio::co_spawn(d.ioc, d.tick_loop(), asio::detached);
  d.ioc.run();
  d.stopping = true;
  d.client.set_heartbeat(std::chrono::milliseconds(0));
}

void ConsoleServer::stop() {
  auto& d = *impl_;
  d.stopping = true;
  asio::post(d.ioc, [&d] {
    error_code ec;
    d.acceptor.close(ec);
    for (const auto& s : d.sessions) {
      s->closed = true;
      s->wake.cancel();
      s->ws.next_layer().close(ec);
    }
    d.ioc.stop();
  });
}

}  // namespace ajar::console
