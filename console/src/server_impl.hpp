// ConsoleServer's state and its member functions, one file per job (the threads and the safety rule
// are in ajar/console/server.hpp):
//   server.cpp        start, run, stop; the Asio thread's tick (state broadcast); the log
//   http.cpp          accepting connections; HTTP: the page's files, /api/state, the Host guard
//   page_sessions.cpp one WebSocket per page: its reader; the deadman's gate (queues: page_hub.hpp)
//   page_requests.cpp what a page asks (hover, pick, rect, send, commands, jog, approach)
//   state_json.cpp    the console's state as the page's JSON (and the simulated landmarks)
//   daemon_link.cpp   DaemonLink (daemon_link.hpp: the client, its workers: connect, Hello, status)
//                     and the console's side of it: status, events, telemetry
//   frames.cpp        the frame thread: paces the source, encodes PNGs for the pages
//   foxglove_live.cpp Foxglove live: the channels and messages (its server: foxglove_server.cpp)
//   recorder_panel.cpp the black box's state and "save the last 5 minutes"
// Members are touched only by the thread named at their group; the rest is posted (on_io).
#pragma once

// <utility> before any Asio header (asio issue 944).
#include <utility>

#include <boost/asio/awaitable.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "ajar/client/client.hpp"
#include "ajar/client/json.hpp"
#include "ajar/console/door_scene.hpp"
#include "ajar/console/frame.hpp"
#include "ajar/console/page_message.hpp"
#include "ajar/console/pick_board.hpp"
#include "ajar/console/pick_pose.hpp"
#include "ajar/console/server.hpp"
#include "ajar/core/geometry.hpp"
#include "daemon_link.hpp"
#include "foxglove_live.hpp"
#include "net_names.hpp"
#include "page_hub.hpp"
#include "worker.hpp"

namespace ajar::console {

// A frame with the base pose it was taken at and its WebSocket messages (frames.cpp).
struct FrameEntry {
  Frame frame;
  BasePose pose;                // the newest odometry when the frame was captured
  Clock::time_point captured;   // when the source delivered it
  Clock::time_point pose_from;  // when that odometry arrived (telemetry); epoch: none yet
  std::shared_ptr<const std::string> colour;  // null when no page was connected
  std::shared_ptr<const std::string> depth;   // null when no page asked for the overlay
};

struct ConsoleServer::Impl final : DaemonLink::Listener {
  Impl(ConsoleOptions o, std::unique_ptr<FrameSource> s, SimulatedSource* sim_source)
      : options(std::move(o)), source(std::move(s)), sim(sim_source), acceptor(ioc) {}

  ConsoleOptions options;
  std::unique_ptr<FrameSource> source;
  SimulatedSource* sim;
  asio::io_context ioc{1};
  tcp::acceptor acceptor;
  std::uint16_t port = 0;
  DaemonLink link{options, *this};  // ajard: the client and its worker threads

  // ---- State owned by the Asio thread ----
  PageHub pages;  // the open pages' WebSockets (any_page, overlay_wanted: read by the frame thread)
  std::deque<std::shared_ptr<const FrameEntry>> frames;  // newest last
  std::string source_error;
  bool daemon_connected = false;
  std::string connection_message = "connecting";
  std::optional<protocol::Welcome> welcome;
  std::optional<protocol::Status> status;
  std::optional<core::CameraToBase> camera_to_base;  // from the daemon (RobotModel)
  std::optional<protocol::RobotModel> model;         // protocol 1.1: GetRobotModel
  PickBoard board;                                   // the operator's picks and each step's reply
  client::JsonObject last_command;  // {"op", "reply", "at"} of the last command; empty before one
  // Honest state (issue 23): who controls, what moves, how old the daemon's word is.
  std::optional<protocol::Role> role_now;  // the role the daemon gives this console's session now
  std::string controller_text;             // the daemon's last control_changed detail
  std::string motion;                      // "aligning", "jogging", ... from motion events
  std::optional<protocol::Telemetry> telemetry;  // the newest sample
  Clock::time_point telemetry_at{};              // when it arrived
  core::PlanarPose broadcast_pose;               // the pose the last state snapshot was made at
  std::string last_drive_refusal;                // the last refused Drive's reply (log throttle)
  Clock::time_point last_drive_refusal_at{};
  std::deque<std::string> log;
  bool heartbeat_on = false;
  bool state_dirty = true;

  // ---- Shared with the frame thread ----
  std::mutex pose_mutex;
  BasePose pose;
  Clock::time_point pose_at{};  // when `pose` arrived (telemetry); epoch: never
  std::atomic<bool> stopping{false};
  std::thread frame_thread;
  // Foxglove live (foxglove_live.hpp): null when off; its methods never block the caller.
  std::unique_ptr<FoxgloveLive> foxglove;
  std::uint16_t foxglove_port = 0;

  // Posting to the Asio thread (from any thread).
  template <typename F>
  void on_io(F&& f) {
    asio::post(ioc, std::forward<F>(f));
  }

  // ---- server.cpp (Asio thread) ----
  void add_log(const std::string& text);  // time-stamped, kept (last 200) and sent to the pages
  static std::string now_hms();
  void mark_dirty() { state_dirty = true; }  // the next tick broadcasts the state
  asio::awaitable<void> tick_loop();

  // ---- http.cpp (Asio thread) ----
  asio::awaitable<void> accept_loop();
  asio::awaitable<void> serve(tcp::socket socket);
  bool host_allowed(const http::request<http::string_body>& req) const;
  std::string foxglove_json() const;  // /api/foxglove

  // ---- page_sessions.cpp (Asio thread) ----
  asio::awaitable<void> run_session(std::shared_ptr<WsSession> s);
  void update_heartbeat();  // feeds the deadman only while a page is connected and alive

  // ---- page_requests.cpp (Asio thread) ----
  void handle_page(const std::shared_ptr<WsSession>& s, const std::string& text);
  std::shared_ptr<const FrameEntry> frame_for(const PageMessage& m) const;
  void hover(const std::shared_ptr<WsSession>& s, const PageMessage& m);
  void pick(const std::shared_ptr<WsSession>& s, const PageMessage& m);
  void rect(const std::shared_ptr<WsSession>& s, const PageMessage& m);
  // Why a pick on `f` is refused: a frozen camera; with pose_too also an unknown base pose.
  std::string frame_problem(const FrameEntry& f, bool pose_too) const;
  void refuse_pick(const std::shared_ptr<WsSession>& s, const std::string& field,
                   const std::string& message);
  void send_step(const std::shared_ptr<WsSession>& s);
  void command(const std::string& op, bool clear);
  void drive(const std::shared_ptr<WsSession>& s, const PageMessage& m);
  void approach(const std::shared_ptr<WsSession>& s, const PageMessage& m);
  void log_response(const std::string& what, const client::Response& r);
  void on_reply(const client::Response& r);  // NOT_CONTROLLER: the daemon demoted this session
  // The pose now and how old it is; nullopt when no telemetry came within kTelemetryStaleAfter.
  std::optional<core::PlanarPose> pose_now(std::string& why) const;
  StaleRule stale_rule() const;
  BoardView board_view() const;  // the pose now (newest telemetry), calibration, staleness rule
  std::string frame_json(const FrameEntry& f) const;  // {"type":"frame"}: age, pose, markers

  // ---- state_json.cpp (Asio thread) ----
  std::string snapshot() const;              // {"type":"state",...}: everything the page draws
  client::JsonObject guidance_json() const;  // door distance, view limits, default standoff, hinge
  std::vector<Landmark> landmarks_now(const core::PlanarPose& now) const;
  std::string landmarks_json() const;  // /api/sim/landmarks; "null" without a simulated source

  // ---- daemon_link.cpp (DaemonLink's listener: posts to the Asio thread; client callbacks) ----
  void connect_failed(const std::string& why) override;
  void hello_refused(const std::string& why) override;
  void connected(const protocol::Welcome& welcome) override;
  void robot_model(const client::Response& reply) override;
  void status_received(const protocol::Status& status) override;
  void worker_idle(bool connected_now) override;  // the black box's poll
  void set_model(const protocol::RobotModel& m);  // Asio thread
  void on_telemetry(const protocol::Telemetry& t);
  void on_event(const protocol::Event& e);
  void on_event_io(const protocol::Event& e, std::uint64_t session_id);  // Asio thread

  // ---- frames.cpp (frame thread) ----
  void frame_loop();

  // ---- recorder_panel.cpp: the black box (ajard's recorder, protocol 1.2) ----
  static constexpr double kSaveLast_s = 300;  // "save the last 5 minutes"
  client::JsonObject recorder_state;  // Asio thread: {"known":false,"why":...} until ajard says
  client::JsonObject recorder_save;   // Asio thread: the last save's answer; empty before one
  Clock::time_point next_recorder_poll{};  // worker thread
  void refresh_recorder();  // worker thread: every 2 s while idle, after a connect and a save
  void recorder_status(const protocol::Status& s);  // worker thread: Status.recorder (1.2)
  void set_recorder_state(client::JsonObject o);    // any thread: posted to the Asio thread
  void save_recording(double last_s);  // Asio thread: the page's "save_recording {last_s}"
};

}  // namespace ajar::console
